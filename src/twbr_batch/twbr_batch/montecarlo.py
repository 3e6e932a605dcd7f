"""montecarlo: one scenario over many seeds, headless on the cores, optionally with perturbed robots.

    python -m twbr_batch.montecarlo dynamic_obstacles -n 1000 --perturb 0.2   # or: make montecarlo N=1000
    python -m twbr_batch.montecarlo dynamic_obstacles -n 1000 --scheduler tcp://10.0.0.5:8786   # Dask

Each run is the simulator, controller and planner (or the scenario's command profile) in closed loop,
ended like the node graph ends it: on the target reached (end_on_target), a fall, or the scenario's
duration. The world is assessed at the world rate, as sim_node does. With --perturb p every run draws,
from its seed, a factor in [1 - p, 1 + p] for each of the body and wheel masses, the inertias and the
motor constant.

Engines: `batch` (default) runs the seeds in chunks through the batch engine (twbr_batch.batch), whose
threads use every core; `scalar` runs each seed through the scalar cores (twbr_batch.closed_loop), one
process per core, as a cross-check. With --scheduler the batch chunks run on a Dask distributed cluster
(every worker needs twbr installed, as here). Each finished row is written to the CSV at once, so an
interrupted study keeps them. Writes <out>/<scenario>-<time>/runs.csv, summary.json and summary.png.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import signal
import sys
import time
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, fields
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from twbr_batch.batch import (
    PLANNER_RATE,
    WORLD_RATE,
    Z_COLLISIONS,
    Z_FALLEN,
    Z_LIFT_EVENTS,
    Z_MIN_CLEARANCE,
    Z_PITCH_MAX,
    Z_PITCH_MIN,
    Z_REACHED_AT,
    Z_SIM_TIME,
    Z_SLIP_EVENTS,
    Z_STUCK_STEPS,
    run_batch,
)
from twbr_common.jit import loading_kernels
from twbr_common.params import ConfigError, defaults
from twbr_common.timing import Decimator
from twbr_control.cascade import CONTROLLERS
from twbr_sim.robot_params import ROBOT_SPECS, robot_params
from twbr_sim.scenario import PERCEPTIONS, load_scenario, run_perception
from twbr_sim.scenario_files import SENSOR_PRESETS, find_scenario, sensor_preset

PERTURBED = ("body_mass", "wheel_mass", "wheel_inertia", "wheel_yaw_inertia", "body_inertia_roll",
             "body_inertia_pitch", "body_inertia_yaw", "motor_constant")
ENGINES = ("batch", "scalar")
# Robots per batch. A batch's last runs step with its lane groups part-empty, once per batch: 1000 runs of
# dynamic_obstacles took 2.64 s in one batch, 2.97-3.14 s in four of 250 (benchmarks/README.md, issue 19
# part 5). The progress bar moves once per batch.
CHUNK = 1000
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


@dataclass(frozen=True)
class Study:
    scenario: Path
    runs: int
    perturbation: float = 0.0
    first_seed: int = 1
    sensors: str = "ideal"  # or "realistic" (config/sensors_realistic.yaml)
    controller: str = "pid"  # or "lqr"
    perception: str | None = None  # "truth" or "lidar" (None: the scenario's own)

    def __post_init__(self) -> None:
        if self.perception is not None and self.perception not in PERCEPTIONS:
            raise ConfigError(f"invalid perception {self.perception!r}: must be one of {', '.join(PERCEPTIONS)}")
        if self.sensors not in SENSOR_PRESETS:
            raise ConfigError(f"invalid sensors {self.sensors!r}: must be one of {', '.join(SENSOR_PRESETS)}")
        if self.controller not in CONTROLLERS:
            raise ConfigError(f"invalid controller {self.controller!r}: must be one of {', '.join(CONTROLLERS)}")
        if self.runs < 1:
            raise ConfigError(f"invalid number of runs {self.runs}: must be at least 1")
        if not 0.0 <= self.perturbation < 1.0:
            raise ConfigError(f"invalid perturbation {self.perturbation:g}: must be in [0, 1) (0.2 means ±20 %)")
        if self.first_seed < 0:
            raise ConfigError(f"invalid first seed {self.first_seed}: must be >= 0")

    @property
    def seeds(self) -> range:
        return range(self.first_seed, self.first_seed + self.runs)

    @property
    def perceived(self) -> str:
        """What the planner sees in this study: its choice, else the scenario's."""
        return run_perception(load_scenario(self.scenario), self.perception)


@dataclass(frozen=True)
class StudyRow:
    """One run of a study: a row of runs.csv (the perturbation factors as `<parameter>_factor` columns)."""

    seed: int
    perturbation: float  # the study's ±fraction
    reached: bool
    time_to_reach_s: float | None  # sim time the target was first inside its capture radius
    collisions: int
    min_clearance_m: float | None  # to the nearest obstacle's surface; None without obstacles
    pitch_min_rad: float
    pitch_max_rad: float
    fallen: bool
    stuck_time_s: float  # sim time the planner reported a local minimum
    sim_time_s: float  # when the run ended
    wheel_lift_events: int  # times a wheel began to lift (traction)
    wheel_slip_events: int  # times a wheel began to slip
    factors: dict[str, float]  # PERTURBED parameter -> factor on its nominal value

    @property
    def succeeded(self) -> bool:
        """Reached the target, without a collision or a fall."""
        return self.reached and not self.fallen and not self.collisions

    def csv_fields(self) -> dict[str, str]:
        values = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "factors"}
        values.update({f"{name}_factor": self.factors[name] for name in PERTURBED})
        return {k: csv_text(v) for k, v in values.items()}


COLUMNS = (*(f.name for f in fields(StudyRow) if f.name != "factors"), *(f"{name}_factor" for name in PERTURBED))


def csv_text(value: Any) -> str:
    """A CSV cell: empty for None, floats to 6 significant digits."""
    if value is None:
        return ""
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def perturbation_factors(seed: int, fraction: float) -> dict[str, float]:
    """The run's factors on PERTURBED, drawn from its seed alone (the same seed, the same robot)."""
    if fraction == 0.0:
        return dict.fromkeys(PERTURBED, 1.0)
    rng = np.random.default_rng([seed, 0x6D63])  # a stream apart from the world's, which uses the seed too
    return {name: float(rng.uniform(1.0 - fraction, 1.0 + fraction)) for name in PERTURBED}


def perturbed_robot(factors: dict[str, float]) -> dict[str, float]:
    """The robot parameters, scaled by a run's perturbation factors, that may differ from the defaults."""
    nominal = defaults(ROBOT_SPECS)
    return {name: nominal[name] * factors[name] for name in PERTURBED}


def run_chunk(scenario_path: str, seeds: list[int], perturbation: float, sensors: str = "ideal",
              controller: str = "pid", duration: float | None = None, perception: str = "truth") -> list[StudyRow]:
    """Runs of the scenario for `seeds` through the batch engine: CSV rows, by seed (`duration`: the
    scenario's unless given; `perception`: what the planner sees, run_batch's)."""
    scenario = load_scenario(Path(scenario_path))
    factors = [perturbation_factors(seed, perturbation) for seed in seeds]
    params = np.stack([robot_params(perturbed_robot(f)) for f in factors])
    table = run_batch(scenario, seeds, params, control={"controller": controller}, planner_rate=PLANNER_RATE,
                      world_rate=WORLD_RATE, sim=sensor_preset(sensors), duration=duration,
                      perception=perception).table
    return [
        StudyRow(
            seed=seed, perturbation=perturbation, reached=not math.isnan(z[Z_REACHED_AT]),
            time_to_reach_s=finite_or_none(z[Z_REACHED_AT]), collisions=int(z[Z_COLLISIONS]),
            min_clearance_m=finite_or_none(z[Z_MIN_CLEARANCE]), pitch_min_rad=float(z[Z_PITCH_MIN]),
            pitch_max_rad=float(z[Z_PITCH_MAX]), fallen=bool(z[Z_FALLEN]),
            stuck_time_s=float(z[Z_STUCK_STEPS]) / PLANNER_RATE, sim_time_s=float(z[Z_SIM_TIME]),
            wheel_lift_events=int(z[Z_LIFT_EVENTS]), wheel_slip_events=int(z[Z_SLIP_EVENTS]), factors=run_factors,
        )
        for seed, run_factors, z in zip(seeds, factors, table, strict=True)
    ]


def run_one(scenario_path: str, seed: int, perturbation: float, sensors: str = "ideal",
            controller: str = "pid", perception: str = "truth") -> StudyRow:
    """One run of the scenario on the scalar cores (the nodes' classes): a CSV row."""
    return run_one_traced(scenario_path, seed, perturbation, sensors=sensors, controller=controller,
                          perception=perception)[0]


def run_one_traced(scenario_path: str, seed: int, perturbation: float,
                   planner: Mapping[str, Any] | None = None, sensors: str = "ideal",
                   controller: str = "pid", perception: str = "truth") -> tuple[StudyRow, Any]:
    """run_one, and the run's closed_loop.Trace; `planner`: planner parameters other than the defaults;
    `perception`: what the planner sees (closed_loop.PlannerReference's)."""
    from twbr_batch.closed_loop import PlannerReference, run_closed_loop, scenario_reference
    from twbr_planner.apf import Mode

    scenario = load_scenario(Path(scenario_path))
    factors = perturbation_factors(seed, perturbation)
    robot = perturbed_robot(factors)
    planner_log: list = []
    plan = PlannerReference(planner, rate=PLANNER_RATE, log=planner_log, perception=perception)
    command = scenario_reference(scenario)
    world = {"reached_at": None, "min_clearance": math.inf, "collisions": 0}
    world_due = Decimator(WORLD_RATE)

    def reference(t: float, sim) -> tuple[float, float]:
        if world_due.due(t):
            a = sim.assess()
            world["min_clearance"] = min(world["min_clearance"], a.clearance)
            world["collisions"] = sim.world.collision_count
            if a.target_reached and world["reached_at"] is None:
                world["reached_at"] = t
        return plan(t, sim) if scenario.target is not None else command(t, sim)

    def ended(_sim) -> bool:
        return scenario.end_on_target and world["reached_at"] is not None

    trace = run_closed_loop(scenario.duration, reference, {"controller": controller}, robot=robot,
                            sim=sensor_preset(sensors), scenario=scenario, seed=seed, stop=ended)
    stuck = sum(1 for out in planner_log if out.mode is Mode.STUCK) / PLANNER_RATE
    pitch = trace.pitch_true
    row = StudyRow(
        seed=seed, perturbation=perturbation, reached=world["reached_at"] is not None,
        time_to_reach_s=world["reached_at"], collisions=world["collisions"],
        min_clearance_m=finite_or_none(world["min_clearance"]), pitch_min_rad=float(pitch.min()),
        pitch_max_rad=float(pitch.max()), fallen=bool(trace.fallen), stuck_time_s=stuck,
        sim_time_s=float(trace.t[-1]), wheel_lift_events=trace.traction.lift_events,
        wheel_slip_events=trace.traction.slip_events, factors=factors,
    )
    return row, trace



def _ignore_interrupts() -> None:
    """Workers leave Ctrl-C to the parent, which stops the study and keeps the finished rows."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class Interrupted(KeyboardInterrupt):
    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _interrupt(signum: int, _frame: Any) -> None:
    raise Interrupted(signum)


def writable_dir(path: Path) -> Path:
    """`path`, created if need be, or ConfigError in one line when it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".twbr-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise ConfigError(f"cannot write to --out {path}: {e.strerror or e}") from None
    return path


def _chunks(study: Study, size: int) -> list[list[int]]:
    seeds = list(study.seeds)
    return [seeds[k:k + size] for k in range(0, len(seeds), size)]


def _scalar_rows(study: Study, workers: int) -> Iterator[StudyRow]:
    """Rows as scalar runs finish, at most `workers` at a time (in this process when workers == 1)."""
    path = str(study.scenario)
    if workers == 1:
        for seed in study.seeds:
            yield run_one(path, seed, study.perturbation, study.sensors, study.controller, study.perceived)
        return
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_ignore_interrupts)
    pending: set[Future] = set()
    seeds = iter(study.seeds)
    try:
        while True:
            while len(pending) < 2 * workers:  # a short queue: an interrupt leaves little to cancel
                seed = next(seeds, None)
                if seed is None:
                    break
                pending.add(pool.submit(run_one, path, seed, study.perturbation, study.sensors, study.controller,
                                        study.perceived))
            if not pending:
                return
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield future.result()
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def load_kernels(study: Study, chunk: int) -> None:
    """Load the batch engine's kernels, or compile them (the first run after a change of the sources, ~100 s
    on 2 cores), on 0.1 s of the study's first chunk, and say which: the progress bar's rate and time left,
    and the study's wall time, then count only the runs."""
    loaded = loading_kernels(lambda line: print(f"montecarlo: {line}", flush=True), "the batch engine", 100.0)
    seeds = next(iter(_chunks(study, chunk)))
    run_chunk(str(study.scenario), seeds, study.perturbation, study.sensors, study.controller, 0.1, study.perceived)
    loaded()


def _batch_rows(study: Study, chunk: int) -> Iterator[StudyRow]:
    """Rows chunk by chunk through the batch engine in this process (its threads use every core)."""
    for seeds in _chunks(study, chunk):
        yield from run_chunk(str(study.scenario), seeds, study.perturbation, study.sensors, study.controller,
                             perception=study.perceived)


def _dask_rows(study: Study, chunk: int, scheduler: str) -> Iterator[StudyRow]:
    """Rows as the batch chunks finish on a Dask distributed cluster."""
    from distributed import Client, as_completed

    try:
        client = Client(scheduler, timeout="20s", set_as_default=False)
    except (OSError, ValueError, TypeError) as e:
        raise ConfigError(f"cannot reach the Dask scheduler at {scheduler!r}: {e}") from None
    try:
        futures = [client.submit(run_chunk, str(study.scenario), seeds, study.perturbation, study.sensors,
                                 study.controller, None, study.perceived, pure=False)
                   for seeds in _chunks(study, chunk)]
        try:
            for future in as_completed(futures, loop=client.loop):
                yield from future.result()
        finally:
            client.cancel(futures)
    finally:
        client.close()


def _run_rows(study: Study, engine: str, workers: int, chunk: int, scheduler: str | None
              ) -> Iterator[StudyRow]:
    if scheduler is not None:
        return _dask_rows(study, chunk, scheduler)
    if engine == "scalar":
        return _scalar_rows(study, workers)
    return _batch_rows(study, chunk)


def run_study(study: Study, out_dir: Path, engine: str = "batch", workers: int = 1, chunk: int = CHUNK,
              scheduler: str | None = None, progress: bool = True) -> list[StudyRow]:
    """Run every seed, appending each finished row to out_dir/runs.csv; returns the rows by seed."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows: list[StudyRow] = []
    ok = 0
    started = time.monotonic()
    tty = sys.stderr.isatty()
    with (out_dir / "runs.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        f.flush()
        for row in _run_rows(study, engine, workers, chunk, scheduler):
            writer.writerow(row.csv_fields())
            f.flush()  # a finished run is kept, whatever stops the study
            rows.append(row)
            ok += row.succeeded
            if progress:
                _progress(len(rows), ok, study.runs, time.monotonic() - started, tty)
    if progress and tty:
        print(file=sys.stderr)
    rows.sort(key=lambda r: r.seed)
    _write_csv(out_dir / "runs.csv", rows)  # the whole study, by seed
    return rows


def _write_csv(path: Path, rows: list[StudyRow]) -> None:
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(row.csv_fields() for row in rows)


def _progress(done: int, ok: int, total: int, elapsed: float, tty: bool) -> None:
    """A bar redrawn in place on a terminal; in a log (not a terminal), a line at every tenth of the study
    instead of one per run."""
    if not tty and done < total and done * 10 // total == (done - 1) * 10 // total:
        return
    width = 30
    filled = round(width * done / total)
    eta = elapsed / done * (total - done)
    line = (f"[{'#' * filled}{'.' * (width - filled)}] {done}/{total} runs, {ok} succeeded,"
            f" {elapsed:.0f} s, about {eta:.0f} s left")
    if tty:
        print(f"\r{line} ", end="", file=sys.stderr, flush=True)
    else:
        print(line, file=sys.stderr, flush=True)


def summarise(rows: list[StudyRow], study: Study, wall_s: float, engine: str) -> dict[str, Any]:
    def stats(values: Iterable[float]) -> dict[str, float] | None:
        a = np.array([v for v in values if v is not None], dtype=float)
        if not len(a):
            return None
        return {"min": float(a.min()), "median": float(np.median(a)), "p95": float(np.percentile(a, 95)),
                "max": float(a.max())}

    n = len(rows)
    return {
        "scenario": study.scenario.stem,
        "runs": n,
        "runs_asked": study.runs,
        "first_seed": study.first_seed,
        "perturbation": study.perturbation,
        "sensors": study.sensors,
        "controller": study.controller,
        "perception": study.perceived,
        "success_rate": sum(r.succeeded for r in rows) / n if n else None,
        "reached": sum(r.reached for r in rows),
        "collided": sum(bool(r.collisions) for r in rows),
        "fallen": sum(r.fallen for r in rows),
        "stuck": sum(r.stuck_time_s > 0 for r in rows),
        "wheel_lifted": sum(r.wheel_lift_events > 0 for r in rows),
        "wheel_slipped": sum(r.wheel_slip_events > 0 for r in rows),
        "time_to_reach_s": stats(r.time_to_reach_s for r in rows),
        "min_clearance_m": stats(r.min_clearance_m for r in rows),
        "pitch_abs_max_rad": stats(max(abs(r.pitch_min_rad), abs(r.pitch_max_rad)) for r in rows),
        "wall_time_s": wall_s,
        "engine": engine,
        "cores": os.cpu_count(),
    }


def summary_figure(rows: list[StudyRow], summary: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    n = summary["runs"]
    counts = [summary["reached"], summary["collided"], summary["fallen"], summary["stuck"]]
    axes[0].bar(["reached", "collided", "fallen", "stuck"], [100.0 * c / n for c in counts],
                color=["tab:green", "tab:red", "tab:red", "tab:orange"])
    axes[0].set_ylabel("% of runs")
    axes[0].set_ylim(0, 105)
    axes[0].set_title(f"success {100.0 * summary['success_rate']:.1f} % of {n} runs")
    reach = [r.time_to_reach_s for r in rows if r.time_to_reach_s is not None]
    axes[1].hist(reach, bins=30, color="tab:blue")
    axes[1].set_xlabel("time to reach [s]")
    axes[1].set_ylabel("runs")
    clearance = [r.min_clearance_m for r in rows if r.min_clearance_m is not None]
    axes[2].hist(clearance, bins=30, color="tab:purple")
    axes[2].axvline(0.0, color="tab:red", lw=1)
    axes[2].set_xlabel("min clearance to an obstacle [m]")
    pert = summary["perturbation"]
    fig.suptitle(f"{summary['scenario']}: seeds {summary['first_seed']}..{summary['first_seed'] + n - 1}"
                 + (f", robot parameters ±{100 * pert:g} %" if pert else ", nominal robot"))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="montecarlo", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", help="a scenario name (config/scenarios) or file")
    ap.add_argument("-n", "--runs", type=int, default=100, help="how many seeds (default 100)")
    ap.add_argument("--perturb", type=float, default=0.0,
                    help="perturb masses, inertias and the motor constant by up to this fraction (0.2: ±20 %%)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--sensors", choices=SENSOR_PRESETS, default="ideal",
                    help="the robot's sensors: ideal (default), or realistic (config/sensors_realistic.yaml: raw IMU"
                         " with noise, bias and delay, 1024-count encoders; the controller estimates pitch)")
    ap.add_argument("--controller", choices=CONTROLLERS, default="pid", help="control law (default pid)")
    ap.add_argument("--perception", choices=PERCEPTIONS,
                    help="what the planner sees: lidar (the simulated scan and target detector through the tracker's"
                         " kernels) or truth (the world's); default: the scenario's (truth for the paper's three)")
    ap.add_argument("--engine", choices=ENGINES, default="batch",
                    help="batch: the batch engine, threads on every core (default); scalar: the nodes' core classes,"
                         " one process per core (a cross-check, about 100 times slower)")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                    help="scalar engine: processes (default: the cores)")
    ap.add_argument("--chunk", type=int, default=CHUNK, help=f"batch engine: robots per batch (default {CHUNK})")
    ap.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the batches on the Dask distributed cluster of this scheduler (e.g."
                         " tcp://127.0.0.1:8786); every worker needs twbr installed")
    ap.add_argument("--out", type=Path, default=Path("runs") / "montecarlo")
    ap.add_argument("--no-figure", action="store_true")
    opts = ap.parse_args(argv)
    try:
        study = Study(find_scenario(opts.scenario), opts.runs, opts.perturb, opts.first_seed, opts.sensors,
                      opts.controller, opts.perception)
        if opts.workers < 1:
            raise ConfigError(f"invalid --workers {opts.workers}: must be at least 1")
        if opts.chunk < 1:
            raise ConfigError(f"invalid --chunk {opts.chunk}: must be at least 1")
        if opts.scheduler is not None and opts.engine != "batch":
            raise ConfigError("--scheduler runs the batch engine: leave out --engine scalar")
        if load_scenario(study.scenario).target is None:
            raise ConfigError(f"scenario {study.scenario}: has no target, and a study measures reaching it"
                              " (run a scripted scenario with run_scenario)")
        writable_dir(opts.out)
    except ConfigError as e:
        print(f"montecarlo: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    where = (f"the Dask cluster at {opts.scheduler}" if opts.scheduler else
             f"{opts.workers} processes (scalar engine)" if opts.engine == "scalar" else
             f"the batch engine ({os.cpu_count()} cores, {opts.chunk} robots per batch)")
    out_dir = opts.out / f"{study.scenario.stem}-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    print(f"montecarlo: {study.runs} runs of {study.scenario.stem} (seeds {study.seeds.start}.."
          f"{study.seeds.stop - 1}, perturbation {study.perturbation:g}, {study.sensors} sensors,"
          f" {study.controller}, perception {study.perceived}) on {where} -> {out_dir}",
          flush=True)
    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, _interrupt)
    try:
        if opts.engine == "batch" and not opts.scheduler:
            load_kernels(study, opts.chunk)
        started = time.monotonic()
        rows = run_study(study, out_dir, opts.engine, opts.workers, opts.chunk, opts.scheduler)
    except ConfigError as e:
        print(f"\nmontecarlo: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as e:
        csv_path = out_dir / "runs.csv"
        kept = sum(1 for _ in csv_path.open()) - 1 if csv_path.exists() else 0
        print(f"\nmontecarlo: interrupted; {kept} finished runs kept in {csv_path}", file=sys.stderr)
        return 128 + e.signum if isinstance(e, Interrupted) else EXIT_INTERRUPTED  # 143 on SIGTERM, as the runner
    summary = summarise(rows, study, time.monotonic() - started, "dask" if opts.scheduler else opts.engine)
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if not opts.no_figure:
        summary_figure(rows, summary, out_dir / "summary.png")
    t = summary["time_to_reach_s"]
    print(f"montecarlo: success {100.0 * summary['success_rate']:.1f} % ({summary['reached']} reached,"
          f" {summary['collided']} collided, {summary['fallen']} fell, {summary['stuck']} with time stuck);"
          + (f" time to reach median {t['median']:.1f} s, p95 {t['p95']:.1f} s;" if t else "")
          + f" {summary['runs']} runs in {summary['wall_time_s']:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
