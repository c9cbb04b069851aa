"""Long jobs say where they stand in a log too (off a terminal tqdm draws nothing)."""


from tangle_drake.common.progress import Progress
from tangle_drake.tangle_data.collect_progress import CollectProgress


def test_off_a_terminal_a_job_prints_lines_with_its_figures_and_the_time_left(capsys):
    progress = Progress(10, 2, "trial", "bench", interval=0.0)
    progress.update(3, "7 parts delivered")
    progress.close()
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1
    assert "bench: 5/10 trials, 7 parts delivered" in lines[0]
    assert "min left" in lines[0]


def test_lines_come_at_most_once_per_interval_and_not_at_all_when_switched_off(capsys):
    slow = Progress(10, 0, "trial", "bench", interval=3600.0)
    silent = Progress(10, 0, "trial", "bench", enabled=False, interval=0.0)
    for _ in range(5):
        slow.update(1, "")
        silent.update(1, "")
    assert capsys.readouterr().out == ""


def test_a_collection_reports_its_samples_and_balance(capsys):
    counts = {"samples": 4, "tangled": 1}
    progress = CollectProgress("collect u_hook", 20, counts, line_interval=0.0)
    progress.task_done({"samples": 6, "tangled": 3})
    alone = progress.per_minute_per_worker()
    assert alone > 0
    progress.running(2)
    progress.close()
    out = capsys.readouterr().out
    assert "collect u_hook: 10/20 samples, tangled 40%, skipped 0" in out
    # The rate is per worker that ran: two at once halve it; a pool's unused size does not.
    assert progress.per_minute_per_worker() <= alone / 2  # the clock only lowers the rate
    progress.running(1)
    assert progress.workers == 2


def test_a_pick_collection_reports_what_came_up(capsys):
    from tangle_drake.tangle_data.physical import PICK_SHARES

    counts = {"samples": 5, "tangled": 1, "one": 3, "none": 1, "failed": 2}
    progress = CollectProgress("collect s_hook", 20, counts, line_interval=0.0,
                               shares=PICK_SHARES)
    progress.task_done({"samples": 5, "tangled": 0, "one": 4, "none": 1, "failed": 0})
    progress.close()
    out = capsys.readouterr().out
    assert "10/20 samples, one part 70%, several 10%, none 20%, skipped 2" in out
