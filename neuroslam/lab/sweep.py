"""Many drives at once on Ray: every (world, seed, parameter setting) as one task (``neuroslam sweep``).

Glue, like the command line: it imports Ray (an optional extra, ``pip install "neuroslam[scale]"``) and,
inside each task, the simulator. Each task builds its configuration and runs the runner
(:func:`neuroslam.lab.runner.run`) on a scripted drive in its worker process, as ``neuroslam drive`` does, with
its own output folder, and returns that drive's ``metrics.json`` (or its one-line error). The results land in
``results.csv``, one row per drive: ``world, seed, status`` (``ok`` or ``failed``), ``error``, the grid's
values, and every number of the drive's metrics flattened with dots (``ate_rmse_m.slam``, ...). Running
the same sweep into the same folder again skips the drives already ``ok``.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InvalidParameterError
from .frames import ODOMETRY_MODES

__all__ = ["Drive", "expand_worlds", "parse_grid", "run_sweep"]

SUMMARY_METRICS = ("ate_rmse_m.slam", "ate_rmse_m.odometry", "map_rmse_m", "loop_closures", "false_loop_closures",
                   "level_accuracy", "ms_per_frame.total")


@dataclass(frozen=True)
class Drive:
    """One drive of a sweep: a world, a sensor-noise seed and a parameter setting (dotted field → value)."""

    world: str
    seed: int
    setting: tuple[tuple[str, Any], ...]

    @property
    def key(self) -> tuple[str, str, str]:
        """What identifies it in ``results.csv``: world, seed, and the setting as JSON."""
        return self.world, str(self.seed), json.dumps(dict(self.setting), sort_keys=True)

    @property
    def folder_name(self) -> str:
        setting = "-".join(f"{field}={value}" for field, value in self.setting)
        name = f"{self.world}-seed{self.seed}" + (f"-{setting}" if setting else "")
        return re.sub(r"[^A-Za-z0-9._=-]+", "_", name)


def expand_worlds(items: list[str]) -> list[str]:
    """World names from the command line: built-in names, ``gen:SEED``, ``gen:A-B`` ranges (inclusive; also
    ``genN:A-B`` for generator version N) and MJCF paths, separated by spaces or commas."""
    worlds = []
    for item in items:
        for name in filter(None, (part.strip() for part in item.split(","))):
            match = re.fullmatch(r"(gen\d*):(-?\d+)-(-?\d+)", name)
            if match:
                prefix, first, last = match.group(1), int(match.group(2)), int(match.group(3))
                if last < first:
                    raise InvalidParameterError("--worlds", name, f"a {prefix}:A-B range needs A <= B")
                worlds.extend(f"{prefix}:{seed}" for seed in range(first, last + 1))
            else:
                worlds.append(name)
    if not worlds:
        raise InvalidParameterError("--worlds", items, "names no world")
    return worlds


def _value(text: str) -> Any:
    """A grid value: JSON if it parses (numbers, true/false, lists), else the text itself."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def parse_grid(items: list[str]) -> list[tuple[tuple[str, Any], ...]]:
    """``FIELD=V1,V2`` items (dotted configuration fields) → every combination of their values."""
    from ..config import Config

    axes = []
    for item in items:
        field, separator, values = item.partition("=")
        if not separator or not field or not values:
            raise InvalidParameterError("--grid", item, "must be FIELD=V1,V2,... (e.g. local_view.threshold=0.05,0.07)")
        parsed = [_value(value) for value in values.split(",")]
        for value in parsed:  # every value must make a valid configuration: fail before any drive starts
            Config.from_dict(_nested(field, value))
        axes.append([(field, value) for value in parsed])
    return [tuple(combination) for combination in itertools.product(*axes)] if axes else [()]


def _nested(field: str, value: Any) -> dict:
    """``a.b`` and a value → ``{"a": {"b": value}}``."""
    data: dict = {}
    target = data
    *parents, last = field.split(".")
    for parent in parents:
        target = target.setdefault(parent, {})
    target[last] = value
    return data


def _merge(into: dict, data: dict) -> dict:
    for key, value in data.items():
        if isinstance(value, dict):
            _merge(into.setdefault(key, {}), value)
        else:
            into[key] = value
    return into


def flatten(data: dict, prefix: str = "") -> dict[str, Any]:
    """Nested metrics → ``{"ate_rmse_m.slam": ..., ...}`` (lists as JSON text)."""
    flat = {}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten(value, f"{name}."))
        elif isinstance(value, list):
            flat[name] = json.dumps(value)
        else:
            flat[name] = value
    return flat


def setting_overrides(setting: tuple) -> dict:
    """A sweep setting's (dotted field, value) pairs as nested configuration overrides."""
    overrides: dict = {}
    for field, value in setting:
        _merge(overrides, _nested(field, value))
    return overrides


def setting_config(setting: tuple):
    """The ``sim`` preset with a sweep setting's (dotted field, value) pairs over it: a
    :class:`~neuroslam.config.Config`."""
    from .. import presets
    from ..config import Config

    config = presets.get("sim")
    return Config.from_dict(setting_overrides(setting), base=config) if setting else config


def _run_drive(world: str, seed: int, setting: tuple, laps: int, max_frames: int | None, folder: str,
               odometry: str = "visual", camera: dict[str, float] | None = None) -> dict:
    """One drive in a worker process, as ``neuroslam drive`` makes it: the ``sim`` preset with the setting
    over it, the runner on a scripted drive, every output into ``folder``. Returns its metrics, or the
    one-line error of a failed drive (bad input or a bug: the sweep goes on)."""
    import sim

    from ..slam import NeuroSLAM
    from .frames import DriveStream
    from .runner import run

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    try:
        config = setting_config(setting)
        if setting:
            (out / "setting.json").write_text(json.dumps(setting_overrides(setting)))
        drive = sim.ScriptedDrive(world, laps=laps, max_frames=max_frames, seed=seed,
                                  camera=sim.CameraConfig(**(camera or {})))
        result = run(DriveStream(drive), NeuroSLAM(config), odometry=odometry, progress=False)
        result.write(out)
        return {"status": "ok", "metrics": result.metrics()}
    except Exception as error:  # one row either way: the sweep goes on
        return {"status": "failed", "error": f"{type(error).__name__}: {error}".splitlines()[0]}


def _read_results(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def _write_results(path: Path, rows: list[dict[str, Any]], grid_fields: list[str]) -> None:
    """All rows, columns ``world, seed, status, error``, the grid fields, then every metric (sorted)."""
    first = ["world", "seed", "status", "error", *grid_fields]
    others = sorted({key for row in rows for key in row} - set(first))
    temporary = path.with_suffix(".csv.tmp")
    with temporary.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=first + others, restval="")
        writer.writeheader()
        writer.writerows(rows)
    temporary.replace(path)


def run_sweep(worlds: list[str], seeds: int, grid: list[tuple], out: Path, *, laps: int = 2,
              max_frames: int | None = None, workers: int | None = None, address: str | None = None,
              odometry: str = "visual", camera: dict[str, float] | None = None, progress: bool = True
              ) -> tuple[list[dict[str, Any]], int]:
    """Run every (world, seed, setting) drive not already ``ok`` in ``out/results.csv`` as a Ray task.

    ``odometry`` is the drives' self-motion (``neuroslam drive --odometry``: visual, wheel or
    visual-inertial); one results file holds one kind, so a folder with drives of another kind is refused.
    ``camera``: the simulated camera's noise, ``{"read_noise": ..., "shot_noise": ..., "exposure": ...}`` (grey
    levels, grey levels, s; ``neuroslam drive --read-noise`` and so on); a results folder holds one camera too.
    Returns (all rows, how many drives failed in this run). Ray starts locally with ``workers`` CPUs unless
    ``address`` names a running cluster.
    """
    if odometry not in ODOMETRY_MODES:
        raise InvalidParameterError("--odometry", odometry, f"must be one of {', '.join(ODOMETRY_MODES)}")
    try:
        import ray
    except ImportError:
        raise InvalidParameterError("sweep", "without Ray", "needs Ray: pip install \"neuroslam[scale]\"") from None
    from tqdm import tqdm

    camera = {name: float(value) for name, value in (camera or {}).items() if value}
    unknown = set(camera) - {"read_noise", "shot_noise", "exposure"}
    if unknown:
        raise InvalidParameterError("camera", sorted(unknown), "knows read_noise, shot_noise and exposure")
    out.mkdir(parents=True, exist_ok=True)
    results = out / "results.csv"
    grid_fields = sorted({field for setting in grid for field, _ in setting})
    if not (out / "camera.json").exists():
        (out / "camera.json").write_text(json.dumps(camera, sort_keys=True) + "\n")
    if json.loads((out / "camera.json").read_text()) != camera:
        raise InvalidParameterError("camera", camera, f"{out} holds drives with the camera of {out / 'camera.json'}; "
                                                      "use another --out")
    rows = _read_results(results)
    others = sorted({row["odometry"] for row in rows if row.get("odometry") and row["odometry"] != odometry})
    if others:
        raise InvalidParameterError("--odometry", odometry, f"{results} holds drives with {others[0]} odometry; "
                                                            "use another --out")
    done = {(row["world"], row["seed"], json.dumps({f: _value(row[f]) for f in grid_fields if row.get(f, "") != ""},
                                                   sort_keys=True))
            for row in rows if row.get("status") == "ok"}
    rows = [row for row in rows if row.get("status") == "ok"]  # failed drives are tried again
    drives = [Drive(world, seed, setting) for world in worlds for seed in range(seeds) for setting in grid]
    pending = [drive for drive in drives if drive.key not in done]
    failed = 0
    if pending:
        if address is not None:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        try:
            task = ray.remote(num_cpus=1)(_run_drive)
            futures = {task.remote(drive.world, drive.seed, drive.setting, laps, max_frames,
                                   str(out / "drives" / drive.folder_name), odometry, camera): drive
                       for drive in pending}
            remaining = list(futures)
            with tqdm(total=len(futures), unit="drive", desc="sweep", disable=not progress) as bar:
                while remaining:
                    ready, remaining = ray.wait(remaining, num_returns=1)
                    drive = futures[ready[0]]
                    outcome = ray.get(ready[0])
                    row: dict[str, Any] = {"world": drive.world, "seed": drive.seed, "status": outcome["status"],
                                           "error": outcome.get("error", "")}
                    row.update({field: json.dumps(value) if not isinstance(value, str) else value
                                for field, value in drive.setting})
                    row.update(flatten(outcome.get("metrics", {})))
                    # the world as asked for (an MJCF file's path, not the name its metrics give): what a later
                    # sweep into this folder matches its worlds against
                    row["world"] = drive.world
                    rows.append(row)
                    failed += outcome["status"] != "ok"
                    _write_results(results, rows, grid_fields)  # a crash later loses no finished drive
                    bar.update()
        finally:
            ray.shutdown()
    _write_results(results, rows, grid_fields)
    return rows, failed


def summary(rows: list[dict[str, Any]], grid_fields: list[str]) -> list[tuple[str, ...]]:
    """Per world and grid setting: drives ok / all, and mean ± std of the key metrics over the ok drives."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault((row["world"], *(str(row.get(field, "")) for field in grid_fields)), []).append(row)
    lines = [("world", *grid_fields, "ok", *SUMMARY_METRICS)]
    for key, members in sorted(groups.items()):
        ok = [row for row in members if row.get("status") == "ok"]
        cells = []
        for metric in SUMMARY_METRICS:
            values = [float(row[metric]) for row in ok if row.get(metric) not in (None, "", "None")]
            if not values:
                cells.append("-")
                continue
            mean = sum(values) / len(values)
            spread = math.sqrt(sum((value - mean) ** 2 for value in values) / len(values))
            cells.append(f"{mean:.3g} ± {spread:.2g}")
        lines.append((*key, f"{len(ok)}/{len(members)}", *cells))
    return lines
