"""The bin-picking benchmark (``tangle-drake bench``): methods x parts x trials, paired.

- ``methods``: the methods compared, and the system that switches between them;
- ``trials``: one trial (a pile, one pick per method), run by a worker;
- ``results``: the run's results on disk, resumable;
- ``stats``: Wilson and paired (Newcombe) confidence intervals, McNemar;
- ``report``: tables, plots and the terminal summary;
- ``runner``: the driver (arguments, workers, progress, report).
"""
