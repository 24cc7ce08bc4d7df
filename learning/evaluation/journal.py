"""The comparison's progress on disk: finished runs in a journal beside the outputs, so a run can resume.

``scripts/evaluate.py`` keeps a work folder ``<out>.partial/`` beside its output folder. Every run that
finishes is appended to ``journal.jsonl`` there at once (one JSON line per run, keyed by its task), so
a kill, Ctrl-C or SIGTERM loses only the runs in flight; ``--resume`` reads the journal back, skips the
runs it holds and gives the same final ``runs.csv`` as an uninterrupted run. The journal's first line
records the settings it belongs to; a journal of other settings is refused, never mixed in. The
outputs themselves are written only when every run is done, as one set (``planners.base.fileio.output_set``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import signal
import time
from collections.abc import Sequence
from pathlib import Path

from learning.evaluation.runner import RunContext, run_one, shared_context
from learning.evaluation.tuning import spec_of
from planners.base.fileio import InputError
from planners.tools.benchmark import Run
from planners.tools.parallel import Backend

JOURNAL = "journal.jsonl"
_KIND = "samplergym-evaluation-journal"


def work_folder(out: str | os.PathLike) -> Path:
    """Where the journal of a comparison writing ``out`` lives: ``<out>.partial`` beside it."""
    out = Path(out).absolute()
    return out.with_name(f"{out.name}.partial")


def task_key(task) -> str:
    """A task's identity in the journal: a hash of its ``repr``.

    :func:`run_phase` keys a ``Task`` (query, planner, sampler spec, seed, label) with its ``Protocol``.
    """
    return hashlib.sha256(repr(task).encode()).hexdigest()[:32]


class Journal:
    """Finished runs by task key, appended to ``<folder>/journal.jsonl`` as they arrive."""

    def __init__(self, folder: str | os.PathLike, settings: dict, *, resume: bool) -> None:
        """Open (``resume``) or start afresh the journal in ``folder`` for a comparison of ``settings``.

        Raises:
            InputError: ``resume`` and the journal there was written for other settings, or is not a journal.
        """
        self.folder = Path(folder)
        self.path = self.folder / JOURNAL
        self.settings = json.loads(json.dumps(settings, sort_keys=True, default=str))
        self.done: dict[str, Run] = {}
        self.resumed = 0
        if resume and self.path.is_file():
            self._read()
            self.resumed = len(self.done)
        else:
            shutil.rmtree(self.folder, ignore_errors=True)
        self.folder.mkdir(parents=True, exist_ok=True)
        if not self.path.is_file():
            self.path.write_text(json.dumps({"kind": _KIND, "settings": self.settings,
                                             "started": time.strftime("%Y-%m-%d %H:%M:%S")}) + "\n",
                                 encoding="utf-8")
        self._file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - kept open while runs arrive

    def _read(self) -> None:
        with open(self.path, encoding="utf-8") as f:
            lines = f.read().split("\n")
        try:
            head = json.loads(lines[0])
        except ValueError:
            head = None
        if not isinstance(head, dict) or head.get("kind") != _KIND:
            raise InputError(f"--resume: {self.path} is not an evaluation journal; remove {self.folder} to start over")
        if head.get("settings") != self.settings:
            diff = sorted(k for k in set(self.settings) | set(head.get("settings") or {})
                          if self.settings.get(k) != (head.get("settings") or {}).get(k))
            raise InputError(f"--resume: the journal in {self.folder} was written with other settings "
                             f"({', '.join(diff)}); rerun with those, or without --resume to start over")
        names = {f.name for f in dataclasses.fields(Run)}
        for line in lines[1:]:
            try:  # the last line may be torn by a kill: it and anything unreadable are run again
                entry = json.loads(line)
                run = Run(**{k: v for k, v in entry["run"].items() if k in names})
            except (ValueError, KeyError, TypeError):
                continue
            self.done[entry["key"]] = run

    def add(self, key: str, run: Run) -> None:
        """Record a finished run (flushed at once, so a kill right after keeps it)."""
        self.done[key] = run
        self._file.write(json.dumps({"key": key, "run": dataclasses.asdict(run)}) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def remove(self) -> None:
        """Delete the work folder: the outputs are written and hold every run."""
        self.close()
        shutil.rmtree(self.folder, ignore_errors=True)


#: Progress-bar names of the samplers whose runs are pooled there whatever their parameters.
_POOLED = {"goal_bias": "goal bias", "policy": "policy", "policy_ablation": "constant"}


def _label(run: Run) -> str:
    spec = spec_of(run)
    return _POOLED.get(spec.name, run.sampler) if spec is not None else run.sampler


def run_phase(tasks: Sequence, context: RunContext, backend: Backend, journal: Journal, phase: str,
              progress: bool = True) -> list[Run]:
    """Every task's run, in task order: from the journal where it is there, else run on ``backend`` and recorded.

    ``context`` holds the protocol the runs are made under and what is loaded for them (added to here).
    The progress bar names ``phase`` and, as runs arrive, the sampler of the last one and the mean
    wall time per run of each sampler so far (goal biases pooled), slowest first.
    """
    from tqdm.auto import tqdm

    keys = [task_key((t, context.protocol)) for t in tasks]
    todo = [i for i, k in enumerate(keys) if k not in journal.done]
    cost: dict[str, list[float]] = {}
    for k in keys:
        if k in journal.done:
            r = journal.done[k]
            cost.setdefault(_label(r), []).append(r.wall_time)
    with tqdm(total=len(tasks), initial=len(tasks) - len(todo), desc=phase, disable=not progress,
              smoothing=0.05) as bar:
        def arrived(j: int, run: Run) -> None:
            journal.add(keys[todo[j]], run)
            c = cost.setdefault(_label(run), [0.0, 0])
            c[0] += run.wall_time
            c[1] += 1
            bar.update(1)
            if bar.n % 8 == 0 or bar.n == bar.total:
                means = sorted(((v[0] / max(v[1], 1) * 1e3, s) for s, v in cost.items()), reverse=True)
                bar.set_postfix_str(f"now {_label(run)}; ms/run " +
                                    ", ".join(f"{s} {ms:.0f}" for ms, s in means[:5]), refresh=False)

        # runs restored from the journal count with the same [total, count] form
        cost = {s: [sum(v), len(v)] for s, v in cost.items()}
        if todo:
            sub = [tasks[i] for i in todo]
            backend.map(run_one, sub, context=shared_context(sub, context), progress=False, on_result=arrived)
    return [journal.done[k] for k in keys]


class Interrupted(Exception):
    """SIGTERM (or SIGINT, as ``KeyboardInterrupt``) arrived: stop, say what was kept, exit ``status``."""

    def __init__(self, status: int) -> None:
        super().__init__(f"stopped by signal (exit {status})")
        self.status = status


def stop_on_sigterm() -> None:
    """Turn SIGTERM into :class:`Interrupted` in this (main) process, so pools shut down on the way out."""
    def handler(signum, frame):  # noqa: ARG001 - signal handler signature
        raise Interrupted(143)

    signal.signal(signal.SIGTERM, handler)
