"""The comparison's progress on disk: finished runs in a journal beside the outputs, so a run can resume.

``scripts/evaluate.py`` keeps a work folder ``<out>.partial/`` beside its output folder. Every run that
finishes is appended to ``journal.jsonl`` there at once (one JSON line per run, keyed by its task), so
a kill, Ctrl-C or SIGTERM loses only the runs in flight; ``--resume`` reads the journal back, skips the
runs it holds and gives the same final ``runs.csv`` as an uninterrupted run. The journal's first line
records the settings it belongs to, with the content hashes of the files the runs read (the models and
the maps); a journal of other settings, or one whose files have changed since, is refused, never mixed in.
The outputs themselves are written only when every run is done, as one set (``planners.base.fileio.output_set``).

The work folder holds nothing but the journal. Nothing else in it is ever deleted: a folder holding
other files is refused (:func:`check_work_folder`), and a journal of finished runs is discarded only
when asked (``fresh``), never by a run that was not told to resume.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import signal
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from learning.evaluation.runner import RunContext, run_one, shared_context
from learning.evaluation.tuning import spec_of
from planners.base.fileio import InputError, atomic_write_text, loads_json, short_repr
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


def _ours(name: str) -> bool:
    """Whether a file name in the work folder is one the journal writes: the journal, or its header on the way in."""
    stem, suffix = JOURNAL.split(".", 1)  # atomic_write_text's temporary file: .journal.<pid>-<token>.tmp.jsonl
    return name == JOURNAL or (name.startswith(f".{stem}.") and name.endswith(f".tmp.{suffix}"))


def _journal_head(path: Path) -> tuple[dict | None, int]:
    """The journal's first line (None where it is not an evaluation journal) and its count of other lines."""
    with open(path, "rb") as f:
        first = f.readline()
        runs = sum(1 for line in f if line.strip() and line.endswith(b"\n"))  # a torn last line is no run
    try:
        head = loads_json(first, str(path))
    except InputError:
        head = None
    return (head if isinstance(head, dict) and head.get("kind") == _KIND else None), runs


def check_work_folder(folder: str | os.PathLike, *, resume: bool, fresh: bool = False) -> int:
    """Refuse a work folder a comparison may not use, before any work; returns the finished runs its journal holds.

    Refused (an ``InputError`` naming the folder and what to do): a folder holding any file the
    journal does not write, a ``journal.jsonl`` that is not an evaluation journal, and a journal
    of finished runs when neither ``resume`` nor ``fresh`` is given (a rerun without ``--resume``
    would otherwise discard an interrupted run's work without a word).
    """
    folder = Path(folder)
    if not folder.is_dir():
        return 0
    foreign = sorted(p.name for p in folder.iterdir() if not _ours(p.name))
    if foreign:
        raise InputError(f"{folder} is the work folder of --out, where evaluate.py keeps its journal, and it holds "
                         f"{', '.join(foreign[:3])}{' and more' if len(foreign) > 3 else ''}, which evaluate.py does "
                         "not write; move those files out of it (nothing there is deleted), or choose another --out")
    path = folder / JOURNAL
    if not path.exists():
        return 0
    if not path.is_file():
        raise InputError(f"{path} is not a file; move it away, or choose another --out")
    head, runs = _journal_head(path)
    if head is None:
        raise InputError(f"{path} is not an evaluation journal (its first line is not one); evaluate.py does not "
                         "delete it: move it away, or choose another --out")
    if runs and not resume and not fresh:
        raise InputError(f"{path} holds {runs} finished runs of an interrupted comparison (started "
                         f"{head.get('started', '?')}); pass --resume to continue it, or --fresh to discard it "
                         "and start over")
    return runs


def file_digests(files: Mapping[str, str | os.PathLike]) -> dict[str, str]:
    """The SHA-256 of each named file's content, by its name (``{"--policy runs/a.zip": "ab12..."}``).

    The journal records these with its settings, so ``--resume`` refuses to mix runs of a model or a
    map that changed between the kill and the resume.
    """
    out = {}
    for label, path in sorted(files.items()):
        h = hashlib.sha256()
        try:
            with open(path, "rb") as f:
                for block in iter(lambda f=f: f.read(1 << 20), b""):
                    h.update(block)
        except OSError as exc:
            raise InputError(f"{label}: cannot read {path}: {exc.strerror or exc}") from None
        out[label] = h.hexdigest()
    return out


#: What each field of a journal's runs must hold: a field of ``Run`` by its annotation.
_FIELD_TYPES = {"str": ((str,), "a string"), "int": ((int,), "an integer"), "bool": ((bool,), "true or false"),
                "float": ((int, float), "a number")}


def _check_run(entry: object, where: str) -> tuple[str, Run]:
    """A journal line's key and run, each field of the type ``Run`` declares, or an ``InputError`` naming it."""
    if not isinstance(entry, dict) or not isinstance(entry.get("key"), str) or not isinstance(entry.get("run"), dict):
        raise InputError(f"{where}: expected an object with a \"key\" string and a \"run\" object, got "
                         f"{short_repr(entry)}")
    fields = {f.name: f for f in dataclasses.fields(Run)}
    values = {}
    for name, f in fields.items():
        if name not in entry["run"]:
            if f.default is dataclasses.MISSING:
                raise InputError(f"{where}: the run has no {name!r}")
            continue
        v = entry["run"][name]
        want, words = _FIELD_TYPES[f.type if isinstance(f.type, str) else f.type.__name__]
        if not isinstance(v, want) or (isinstance(v, bool) and bool not in want):
            raise InputError(f"{where}: the run's {name!r} is {short_repr(v)}, expected {words}")
        values[name] = v
    return entry["key"], Run(**values)


class Journal:
    """Finished runs by task key, appended to ``<folder>/journal.jsonl`` as they arrive."""

    def __init__(self, folder: str | os.PathLike, settings: dict, *, resume: bool, fresh: bool = False) -> None:
        """Open (``resume``) or start the journal in ``folder`` for a comparison of ``settings``.

        ``settings`` may hold ``"inputs"``: :func:`file_digests` of the files the runs read. Starting
        afresh removes only the journal; a journal of finished runs is discarded only with ``fresh``.
        ``discarded`` counts the runs discarded so, ``resumed`` the runs read back.

        Raises:
            InputError: Anything :func:`check_work_folder` refuses; ``resume`` and the journal there
                was written for other settings or other files, or a line of it is not a run.
        """
        self.folder = Path(folder)
        self.path = self.folder / JOURNAL
        self.settings = json.loads(json.dumps(settings, sort_keys=True, default=str))
        self.done: dict[str, Run] = {}
        self.resumed = 0
        self.discarded = check_work_folder(self.folder, resume=resume, fresh=fresh)
        if resume and self.path.is_file():
            self._read()
            self.resumed = len(self.done)
            self.discarded = 0
        else:
            self._remove_own_files()
        self.folder.mkdir(parents=True, exist_ok=True)
        if not self.path.is_file():  # written whole, so a kill never leaves a torn first line
            atomic_write_text(self.path, json.dumps({"kind": _KIND, "settings": self.settings,
                                                     "started": time.strftime("%Y-%m-%d %H:%M:%S")}) + "\n")
        self._file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - kept open while runs arrive

    def _remove_own_files(self) -> None:
        """Delete the files the journal writes (and nothing else) from the work folder."""
        if self.folder.is_dir():
            for p in self.folder.iterdir():
                if _ours(p.name) and (p.is_file() or p.is_symlink()):
                    p.unlink(missing_ok=True)

    def _read(self) -> None:
        data = self.path.read_bytes()
        whole = data.rfind(b"\n") + 1
        lines = data[:whole or len(data)].decode("utf-8", errors="replace").split("\n")
        try:
            head = loads_json(lines[0], str(self.path))
        except InputError:
            head = None
        if not isinstance(head, dict) or head.get("kind") != _KIND:
            raise InputError(f"--resume: {self.path} is not an evaluation journal; move it away, or pass --fresh "
                             "without --resume to start over")
        theirs = head.get("settings") if isinstance(head.get("settings"), dict) else {}
        if theirs != self.settings:
            raise InputError(self._mismatch(theirs))
        for lineno, line in enumerate(lines[1:], start=2):
            if not line.strip():
                continue
            where = f"{self.path}, line {lineno}"
            try:
                entry = json.loads(line)
            except RecursionError:
                raise InputError(f"{where}: JSON nested too deep to be a run") from None
            except ValueError:
                raise InputError(f"{where}: not a JSON line; the journal is damaged: pass --fresh without "
                                 "--resume to start over") from None
            try:
                key, run = _check_run(entry, where)
            except InputError as exc:
                raise InputError(f"{exc}; the journal is damaged: pass --fresh without --resume to start "
                                 "over") from None
            self.done[key] = run
        if 0 < whole < len(data):  # the last line torn by a kill: cut off, so the runs that follow start a line
            os.truncate(self.path, whole)

    def _mismatch(self, theirs: dict) -> str:
        """Why a journal written with settings ``theirs`` cannot be resumed now: the changed files, or settings."""
        mine_in, their_in = self.settings.get("inputs") or {}, theirs.get("inputs")
        their_in = their_in if isinstance(their_in, dict) else {}
        changed = [k for k in sorted(set(mine_in) | set(their_in)) if mine_in.get(k) != their_in.get(k)]
        if changed:
            def why(k: str) -> str:
                if k not in their_in:
                    return f"{k}: not read by the journal's runs"
                if k not in mine_in:
                    return f"{k}: read by the journal's runs, not now"
                return f"{k}: its content changed since (sha256 {str(their_in[k])[:12]} then, {mine_in[k][:12]} now)"

            return (f"--resume: the journal in {self.folder} ran other files: {'; '.join(why(k) for k in changed[:3])}"
                    f"{' and more' if len(changed) > 3 else ''}; put back the files it ran, or pass --fresh "
                    "without --resume to start over")
        diff = sorted(k for k in set(self.settings) | set(theirs) if self.settings.get(k) != theirs.get(k))
        return (f"--resume: the journal in {self.folder} was written with other settings ({', '.join(diff)}); "
                "rerun with those, or pass --fresh without --resume to start over")

    def add(self, key: str, run: Run) -> None:
        """Record a finished run (flushed at once, so a kill right after keeps it)."""
        self.done[key] = run
        self._file.write(json.dumps({"key": key, "run": dataclasses.asdict(run)}) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def remove(self) -> None:
        """Delete the journal, and the work folder if that leaves it empty: the outputs hold every run."""
        self.close()
        self._remove_own_files()
        try:
            self.folder.rmdir()
        except OSError:
            pass  # something else arrived there: it stays


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
