"""``tangle-drake teach``: a user's mesh to a trained, tested, benchmarked model, resumably.

Stages, each with a time budget (:data:`BUDGET_MIN`, 30 minutes with two workers in all):

1. ``check``: the mesh check (:mod:`.check`): ``check.txt``/``.json``, ``part.png``,
   ``pile.png``, and ``part.json``, the part file every later stage names as the part (the
   mesh, its scale, a ``--mass`` the user weighed);
2. ``labels``: the auto-lift's labels (``collect``) into ``data/``;
3. ``train``: the tangle CNN into ``model.pt`` (and ``model.onnx`` where ONNX is installed);
4. ``test``: fresh piles of another seed into ``test/`` and the model's figures on them;
5. ``bench``: graspability alone against the model on the same piles, into ``bench/``;
6. ``card``: ``card.md``, the model card: the check, the data, the figures, the benchmark.

``teach.json`` records the run's settings and the finished stages. The same command again
skips what is finished and resumes the stage that was interrupted where it stopped (each
stage is itself resumable: shards, training state, benchmark trials); other settings for
the same directory are refused. A stage is recorded only once it has run to its end: Ctrl-C
within one (the benchmark's trials included) propagates and leaves it to the next run. A run
the check refuses (or whose check raises a refusal) leaves ``--out`` as it found it, so the
same command with the mesh fixed is a new run, not "other settings". :data:`AFTER_STAGE` is
called after each finished stage (a test interrupts a run there).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import trimesh

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.parts import BUILTIN_PARTS, load_part
from tangle_drake.selection.choice import trained_model_path
from tangle_drake.tangle_cnn.train_settings import TRAIN_THREADS
from tangle_drake.teach.check import (
    PartCheck,
    check_part,
    collision_pieces,
    scenario_of,
    settle_verdict,
)

STAGES = ("check", "labels", "train", "test", "bench", "card")
BUDGET_MIN = {"check": 0.5, "labels": 16.5, "train": 2.0, "test": 5.0, "bench": 5.5,
              "card": 0.5}
"""Each stage's share of the 30 minutes a new part may take on the 2-core machine."""
STATE_FILE = "teach.json"
CHECK_FILES = ("part.json", "check.json", "check.txt", "part.png", "pile.png")
"""What the check stage writes into ``--out``: all a run that no stage finished can hold."""
AFTER_STAGE: Callable[[str], None] | None = None
"""Called with each stage's name once it is finished and recorded."""


@dataclass(frozen=True)
class TeachSettings:
    """What ``teach`` was asked for (the run's identity, with the mesh's content)."""

    mesh: str
    """A mesh file, or a built-in part's name (which teaches it by the shipped models' recipe:
    the same labels, the same training, so the same weights)."""
    mesh_scale: float = 1.0
    mass_kg: float | None = None
    samples: int = 1800
    """Labels to collect: the learning curves (``docs/results/learning_curve``) are flat within the
    training's own spread past 1,000 for the U-hook and past 1,800 for the E-shape (rarer
    tangles), and 1,800 of a mesh part leave the whole run within 30 minutes on two cores,
    where 2,000 did not (``docs/teach.md``)."""
    test_samples: int = 500
    bench_trials: int = 20
    epochs: int = 40
    parts_per_pile: int | None = None
    """``None``: the collection's default for the part's size."""
    validation_fraction: float = 0.1
    seed: int = 0

    @staticmethod
    def quick(mesh: str, mesh_scale: float = 1.0, mass_kg: float | None = None,
              seed: int = 0) -> TeachSettings:
        """Every stage, as small as still says something (CI's end-to-end check): enough
        labels, in the part's full piles, that both classes reach the training and
        validation piles."""
        return TeachSettings(mesh, mesh_scale, mass_kg, samples=60, test_samples=20,
                             bench_trials=1, epochs=2, validation_fraction=0.3, seed=seed)


class Teacher:
    """Runs the stages of one ``teach`` directory."""

    def __init__(self, settings: TeachSettings, out: Path, workers: int | None = None,
                 ray: str | None = None, say: Callable[[str], None] = print) -> None:
        self.settings = settings
        self.out = Path(out)
        self.workers = workers
        self.ray = ray
        self.say = say
        self.done: list[str] = []
        self._open()

    @property
    def builtin(self) -> bool:
        """Whether the part is a built-in one (no mesh, no part file)."""
        return self.settings.mesh in BUILTIN_PARTS

    @property
    def part_file(self) -> Path:
        return self.out / "part.json"

    @property
    def part(self) -> str:
        """The part as every later stage names it: the built-in's name, or the part file."""
        return self.settings.mesh if self.builtin else str(self.part_file)

    @property
    def model(self) -> Path:
        return self.out / "model.pt" if self.builtin else trained_model_path(self.part_file)

    def _identity(self) -> dict:
        if self.builtin:
            if self.settings.mesh_scale != 1.0 or self.settings.mass_kg is not None:
                raise TangleDrakeError(f"{self.settings.mesh} is a built-in part, with its own "
                                       "size and mass: --mesh-scale and --mass are for meshes")
            return asdict(self.settings)
        mesh = Path(self.settings.mesh)
        if not mesh.is_file():
            raise TangleDrakeError(f"mesh file not found: {mesh}")
        return {**asdict(self.settings), "mesh": str(mesh.resolve()),
                "mesh_sha256": hashlib.sha256(mesh.read_bytes()).hexdigest()}

    def _open(self) -> None:
        identity = self._identity()
        path = self.out / STATE_FILE
        # The directories this run makes: a refused check takes them away again (_forget).
        self._made = [d for d in (self.out, *self.out.parents) if not d.exists()]
        if path.exists():
            state = json.loads(path.read_text())
            if state.get("identity") != identity:
                raise TangleDrakeError(f"{self.out} holds a teach run of other settings or "
                                       "another mesh; run it with the same arguments to "
                                       "resume it, or choose another --out")
            self.done = list(state.get("done", []))
        elif self.out.exists() and any(self.out.iterdir()):
            raise TangleDrakeError(f"--out {self.out} is not empty and holds no teach run")
        self.out.mkdir(parents=True, exist_ok=True)
        self.identity = identity
        self._save()

    def _save(self) -> None:
        tmp = self.out / (STATE_FILE + ".tmp")
        tmp.write_text(json.dumps({"identity": self.identity, "done": self.done}, indent=1))
        tmp.replace(self.out / STATE_FILE)

    def _forget(self) -> None:
        """Undo a run refused before any stage finished, so that it binds no ``--out``: the
        state and the check's files go (``--out`` was empty when the state was first written,
        and only the check has run since), and so do the directories this run made, where
        that leaves them empty. Nothing else is touched."""
        for name in (STATE_FILE, STATE_FILE + ".tmp", *CHECK_FILES):
            (self.out / name).unlink(missing_ok=True)
        for directory in self._made:  # innermost first; rmdir leaves anything not empty
            try:
                directory.rmdir()
            except OSError:
                break

    def run(self) -> PartCheck:
        """Every stage not yet finished, in order; the check's result (refused: stops, and
        ``--out`` is left as this run found it). ``KeyboardInterrupt`` propagates from the
        stage it stopped, which stays unfinished (the next run resumes it)."""
        check = None
        for number, stage in enumerate(STAGES, 1):
            if stage in self.done:
                self.say(f"[{number}/{len(STAGES)}] {stage}: done before")
                if stage == "check":
                    check = PartCheck(**json.loads((self.out / "check.json").read_text()))
                continue
            left = sum(BUDGET_MIN[s] for s in STAGES[number - 1:])
            self.say(f"[{number}/{len(STAGES)}] {stage}: budget {BUDGET_MIN[stage]:g} min "
                     f"(about {left:g} min left in all)")
            start = time.perf_counter()
            try:
                result = getattr(self, f"_{stage}")()
            except TangleDrakeError:
                if not self.done:  # refused before any work: nothing to keep
                    self._forget()
                raise
            if stage == "check":
                check = result
                if not check.accepted:
                    self._forget()
                    return check
            self.say(f"[{number}/{len(STAGES)}] {stage}: finished in "
                     f"{(time.perf_counter() - start) / 60:.1f} min")
            self.done.append(stage)
            self._save()
            if AFTER_STAGE is not None:
                AFTER_STAGE(stage)
        return check

    # -- the stages ---------------------------------------------------------------------------

    def _check(self) -> PartCheck:
        from tangle_drake.scenario.files import resolve_scenario

        s = self.settings
        scenario = resolve_scenario("floating_gripper.yaml")
        if not self.builtin:
            self.part_file.write_text(json.dumps({"mesh": str(Path(s.mesh).resolve()),
                                                  "mesh_scale": s.mesh_scale,
                                                  "mass_kg": s.mass_kg}, indent=1) + "\n")
        check = check_part(self.part, 1.0, scenario)
        if check.accepted:
            check = self._pile(check, scenario)
        lines = check.lines()
        check.write(self.out / "check.json")
        (self.out / "check.txt").write_text("\n".join(lines) + "\n")
        for line in lines if check.accepted else lines[:-1]:  # a refusal is the caller's error
            self.say(f"  {line}")
        return check

    def _pile(self, check: PartCheck, scenario) -> PartCheck:
        """Write the part file and the pictures; ``check`` with how a settled pile went."""
        from tangle_drake.station.scene import make_scene
        from tangle_drake.teach.pictures import write_pictures

        s = self.settings
        part = load_part(self.part)
        pieces = collision_pieces(self.part)
        pile = scenario_of(scenario, self.part)
        pile.view_cameras = []
        scene = make_scene(pile, seed=s.seed)
        for path in write_pictures(self.out, trimesh.load_mesh(part.visual_mesh_path,
                                                                process=False), pieces,
                                   scene.depth):
            self.say(f"  wrote {path}")
        return settle_verdict(check, scene.report)

    def _collect(self, out: Path, samples: int, seed: int) -> None:
        from tangle_drake.tangle_data.collect import collect, default_scenario_text
        from tangle_drake.tangle_data.defaults import default_parts_per_pile
        from tangle_drake.tangle_data.settings import CollectSettings
        from tangle_drake.tangle_data.simulator import data_scenario

        settings = CollectSettings(part=self.part, seed=seed)
        count = self.settings.parts_per_pile
        if count is None:
            part = load_part(self.part)
            count = default_parts_per_pile(part.name, part, data_scenario(
                default_scenario_text(), settings).bin)
        result = collect(replace(settings, parts_per_pile=count), out, samples,
                         workers=self.workers, ray_address=self.ray)
        if result.interrupted:
            raise KeyboardInterrupt
        self.say(f"  {out}: {result.counts['samples']} samples, "
                 f"{result.counts['tangled']} tangled")

    def _labels(self) -> None:
        self._collect(self.out / "data", self.settings.samples, self.settings.seed)

    def _train(self) -> None:
        import torch

        from tangle_drake.tangle_cnn.train import TrainSettings, train

        s = self.settings
        threads = torch.get_num_threads()
        torch.set_num_threads(TRAIN_THREADS)
        try:
            train(self.out / "data", self.model,
                  TrainSettings(epochs=s.epochs, seed=s.seed,
                                validation_fraction=s.validation_fraction),
                  device="cpu", log=lambda line: self.say(f"  {line}"))
        finally:
            torch.set_num_threads(threads)
        from tangle_drake.tangle_cnn.model import load_tangle_model
        from tangle_drake.tangle_cnn.onnx_export import export_onnx

        try:
            export_onnx(load_tangle_model(self.model), self.out / "model.onnx")
        except TangleDrakeError as error:  # the onnx extra is not installed
            self.say(f"  no ONNX file: {error}")

    def _test(self) -> None:
        from tangle_drake.tangle_cnn.evaluate import evaluate_model
        from tangle_drake.tangle_cnn.model import load_tangle_model

        self._collect(self.out / "test", self.settings.test_samples, self.settings.seed + 1)
        result = evaluate_model(load_tangle_model(self.model), self.out / "test")
        (self.out / "test.json").write_text(json.dumps(result.to_dict(), indent=1) + "\n")
        self.say(f"  on {result.samples} fresh samples: accuracy {100 * result.accuracy:.1f} "
                 f"%, ROC-AUC {'n/a' if result.auc is None else f'{result.auc:.3f}'}")

    def _bench(self) -> None:
        from tangle_drake.bench.runner import BenchOptions, run_bench

        options = BenchOptions(methods=["graspability", f"model:{self.model}"],
                               parts=[self.part], trials=self.settings.bench_trials,
                               workers=self.workers, ray=self.ray, out=self.out / "bench",
                               seed=self.settings.seed,
                               command=f"tangle-drake teach {shown_path(self.settings.mesh)}")
        outcome = run_bench(options, say=lambda line: self.say(f"  {line}"))
        if outcome.interrupted:  # run_bench keeps the finished trials and reports on them
            raise KeyboardInterrupt

    def _card(self) -> None:
        from tangle_drake.teach.card import write_card

        path = write_card(self.out, self.settings.mesh if self.builtin else "part.json")
        self.say(f"  wrote {path}")
