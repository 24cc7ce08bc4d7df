"""A policy training run's logs under ``<run>/tb``: TensorBoard events and a ``progress.csv`` a resumed run continues.

A resumed run redoes the steps after its checkpoint; these writers drop what the killed run logged after
it (``trim_events``, ``ResumableCSV``), so every step appears once.
"""

from __future__ import annotations

import csv
from pathlib import Path

from stable_baselines3.common.logger import KVWriter, Logger, make_output_format

from planners.base.fileio import atomic_path


def trim_events(folder: Path, until: float | None) -> None:
    """Drop the TensorBoard events written after wall time ``until`` (a killed run's, after its checkpoint).

    The redone steps are logged again on resume; kept, TensorBoard would draw each of them twice.
    Each events file is rewritten whole (temporary file, then rename); a file left with nothing after
    its header is removed.
    """
    if until is None or not folder.is_dir():
        return
    from tensorboard.backend.event_processing.event_file_loader import RawEventFileLoader
    from tensorboard.compat.proto import event_pb2
    from tensorboard.summary.writer.record_writer import RecordWriter

    for path in sorted(folder.glob("events.out.tfevents.*")):
        records = list(RawEventFileLoader(str(path)).Load())
        kept = [r for r in records if event_pb2.Event.FromString(r).wall_time <= until]
        if len(kept) == len(records):
            continue
        if len(kept) <= 1:  # at most the file-version header: the whole file came after the checkpoint
            path.unlink()
            continue
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            writer = RecordWriter(f)
            for r in kept:
                writer.write(r)
            writer.flush()


class ResumableCSV(KVWriter):
    """``progress.csv`` that a resumed run continues: rows after the checkpoint are dropped, not the rest.

    A Stable-Baselines3 ``KVWriter``. SB3's own CSV writer truncates the file when it opens it and
    rewrites it in place when a new column appears; this one rewrites atomically and appends otherwise.
    """

    def __init__(self, path: Path, keep_rows: int | None) -> None:
        self.path = path
        self.keys: list[str] = []
        self.table: list[list[str]] = []
        if keep_rows is not None and path.is_file():
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.reader(f))
            if rows:
                self.keys, self.table = rows[0], rows[1:keep_rows + 1]
        self._rewrite()

    @property
    def rows(self) -> int:
        return len(self.table)

    def _rewrite(self) -> None:
        with atomic_path(self.path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            if self.keys:
                w.writerow(self.keys)
            w.writerows(row + [""] * (len(self.keys) - len(row)) for row in self.table)
        self.file = open(self.path, "a", newline="", encoding="utf-8")  # noqa: SIM115 - closed in close()

    def write(self, key_values: dict, key_excluded: dict, step: int = 0) -> None:
        values = {k: v for k, v in key_values.items() if "csv" not in (key_excluded.get(k) or ())}
        new = [k for k in values if k not in self.keys]
        row = ["" if values.get(k) is None else str(values[k]) for k in self.keys + new]
        self.table.append(row)
        if new:
            self.keys += new
            self.file.close()
            self._rewrite()
        else:
            csv.writer(self.file).writerow(row)
            self.file.flush()

    def close(self) -> None:
        self.file.close()


class RunLogger(Logger):
    """SB3 logger whose ``step_offset`` is added to every step: SB3 counts each PPO segment's steps from zero."""

    step_offset = 0

    def dump(self, step: int = 0) -> None:
        if self.step_offset:
            self.record("time/run_timesteps", step + self.step_offset)
        super().dump(step + self.step_offset)


def run_logger(run: Path, keep_rows: int | None, stdout: bool) -> tuple[RunLogger, ResumableCSV]:
    """The run's logger: TensorBoard events and ``progress.csv`` under ``<run>/tb`` (and stdout)."""
    folder = run / "tb"
    folder.mkdir(parents=True, exist_ok=True)
    csv_log = ResumableCSV(folder / "progress.csv", keep_rows)
    formats = [make_output_format("tensorboard", str(folder)), csv_log]
    if stdout:
        formats.append(make_output_format("stdout", str(folder)))
    return RunLogger(str(folder), formats), csv_log
