"""suite: the paper's navigation scenarios and our hard suite, for both planner methods, on the batch engine.

    python -m twbr_batch.suite -n 1000                 # or: make suite N=1000
    python -m twbr_batch.suite -n 200 --ablation       # the robust method with each addition off in turn
    python -m twbr_batch.suite -n 100 --scenarios my_lab.yaml,gap_1m   # your own layouts beside the suite's
    python -m twbr_batch.suite -n 100 --methods robust --perception truth,lidar   # side by side

Every scenario of config/scenarios/suite and the paper's three navigation scenarios run for n seeds (each
seed its own layout where the scenario varies, its own target turns) with a 120 s limit. Every run is
classified (avoidability.classify): success, a collision (avoidable or not, computed from the state at
detection), a fall, trapped, outrun or late. Writes <out>/runs.csv (one row per run), table.md and
summary.json (one row per scenario and method), and figures/<scenario>.png (the field and the first
seeds' paths of each method).

The planner sees what each scenario says (`perception`: the simulated LiDAR and target detector through
the tracker's kernels, or the paper's three, the world's truth) unless --perception chooses; with two
choices every method runs on both, as "<method>" (truth) and "<method> lidar".
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from twbr_batch.avoidability import DT, HORIZON, OUTCOMES, Limits, classify, collision_avoidable, straight_path
from twbr_batch.batch import (
    PLANNER_RATE,
    Z_COLLISIONS,
    Z_DETECTED,
    Z_FALLEN,
    Z_FINAL_DISTANCE,
    Z_HIT_OBSTACLE,
    Z_MIN_CLEARANCE,
    Z_PITCH_SETTLED,
    Z_REACHED_AT,
    Z_SIM_TIME,
    Z_STUCK_AT_END,
    Z_STUCK_STEPS,
    Z_TORQUE_STEP_MAX,
    Z_TRACKING,
    run_batch,
)
from twbr_batch.montecarlo import csv_text, finite_or_none
from twbr_common.params import ConfigError, default_of
from twbr_planner.planner_params import METHODS
from twbr_planner.planner_params import resolve as resolve_planner
from twbr_sim.lidar import LIDAR_SPECS
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import PERCEPTIONS, Scenario, load_scenario, run_perception, vary
from twbr_sim.scenario_files import find_scenario, suite_names
from twbr_sim.world import World
from twbr_tracker.evaluation import JUDGE_LAYOUT, N_JUDGE, TrackingFigures

PAPER_SCENARIOS = ("static", "dynamic_target", "dynamic_obstacles")
TIME_LIMIT = 120.0  # [s]
CHUNK = 250
TRACED_SEEDS = 5  # paths drawn per scenario and method
# The ablation: the robust method with one addition switched off, by the parameter values that do it.
ABLATIONS: dict[str, dict[str, Any]] = {
    "robust": {},
    "no goal fade": {"goal_fade": 0.0},
    "no escape": {"follow_range": 0.0},  # neither the navigation function nor boundary following
    "no dynamic repulsion": {"evade_horizon": 0.0},
    "no speed policy": {"speed_policy": False},
    "no safety filter": {"safety_filter": False},
    "no yielding": {"yield_horizon": 0.0},
    "no dynamic window": {"window_horizon": 0.0},
    "no prediction": {"prediction_strength": 0.0},  # movers on their straight lines only
}


def ablation_variants() -> dict[str, dict[str, Any]]:
    """The ablation's planners, by name: the robust method's parameters with one addition off."""
    return {name: {"method": "robust", **overrides} for name, overrides in ABLATIONS.items()}


@dataclass(frozen=True)
class SuiteRow:
    """One run: a row of runs.csv."""

    scenario: str
    variant: str  # the method, or the ablation's name
    seed: int
    outcome: str  # avoidability.OUTCOMES
    time_to_reach_s: float | None
    collisions: int
    hit_obstacle_id: int  # the first collision's obstacle, -1 none
    min_clearance_m: float | None
    fallen: bool
    stuck_time_s: float
    pitch_abs_max_settled_rad: float  # after the first 2 s
    final_distance_m: float
    sim_time_s: float
    torque_step_max_nm: float = math.nan  # a wheel's largest torque change between two control samples
    perception: str = "truth"  # what the planner's obstacles and target came from: "truth" or "lidar"
    # with the LiDAR: the tracker judged at every scan (evaluation.JUDGE_LAYOUT's sums; runs.csv: track_*)
    tracking: tuple[float, ...] = ()

    @property
    def succeeded(self) -> bool:
        return self.outcome == "success"


COLUMNS = (*(f.name for f in fields(SuiteRow) if f.name != "tracking"), *(f"track_{n}" for n in JUDGE_LAYOUT.names))
SCAN_PERIOD = 1.0 / default_of(LIDAR_SPECS, "lidar.rate")  # [s] the batch's scans (sim_node's default)


def csv_row(row: SuiteRow) -> dict[str, str]:
    """A run as runs.csv's cells."""
    cells = {k: csv_text(v) for k, v in asdict(row).items() if k != "tracking"}
    judged = row.tracking or (None,) * N_JUDGE  # on the truth: empty cells
    cells.update({f"track_{n}": csv_text(v) for n, v in zip(JUDGE_LAYOUT.names, judged, strict=True)})
    return cells


def suite_scenarios() -> list[Path]:
    """The paper's navigation scenarios, then the suite's (config/scenarios/suite), by name."""
    names = [*PAPER_SCENARIOS, *(f"suite/{name}" for name in suite_names())]
    return [find_scenario(name) for name in names]


def obstacle_path(scenario: Scenario, seed: int, index: int, t0: float, horizon: float = HORIZON) -> np.ndarray:
    """Obstacle `index`'s positions every avoidability.DT from t0 [s] over `horizon` in the world of `seed`:
    its straight line, or its motion kind's path replayed in a World with no robot in it."""
    obstacle = vary(scenario, seed).obstacles[index]
    if obstacle.motion is None and obstacle.reaction is None:
        return straight_path((obstacle.x + obstacle.vx * t0, obstacle.y + obstacle.vy * t0, obstacle.vx, obstacle.vy),
                             horizon)
    world = World(scenario, 0.0, seed)
    path = np.empty((int(horizon / DT) + 1, 2))
    for k in range(len(path)):
        world.advance_to(t0 + k * DT)
        path[k] = world.obstacle_positions()[index]
    return path


def chosen_scenarios(text: str) -> list[Path]:
    """--scenarios: comma-separated suite names (`gap_1m`), installed names (`suite/gap_1m`, `static`) or a
    user's scenario files; each must have a target to navigate to."""
    by_stem = {p.stem: p for p in suite_scenarios()}
    paths = []
    for entry in (s.strip() for s in text.split(",")):
        if not entry:
            continue
        try:
            path = by_stem.get(entry) or find_scenario(entry)
        except ConfigError as e:
            raise ConfigError(f"invalid --scenarios entry {entry!r}: not a suite name ({', '.join(sorted(by_stem))})"
                              f" nor a scenario file: {e}") from None
        scenario = load_scenario(path)  # a malformed file is refused here, naming its field
        if scenario.target is None:
            raise ConfigError(f"invalid --scenarios entry {entry!r}: scenario {scenario.name} has no target to"
                              " navigate to (the suite measures navigation)")
        paths.append(path)
    if not paths:
        raise ConfigError(f"invalid --scenarios {text!r}: names no scenario")
    return paths


def robot_limits(planner: Mapping[str, Any]) -> Limits:
    """What the robot is allowed to do, as the run's planner was: the bounds of the avoidability check."""
    braking = planner["max_acceleration"] if planner["method"] == "paper" else planner["brake_deceleration"]
    # the robust method may speed up at window_acceleration among walkers: so may the escapes that judge it
    acceleration = max(planner["max_acceleration"], planner["window_acceleration"] if planner["method"] == "robust"
                       else 0.0)
    return Limits(planner["v_max"], acceleration, braking, planner["max_yaw_rate"], planner["max_yaw_acceleration"])


def split_variant(variant: Mapping[str, Any]) -> tuple[dict[str, Any], str | None]:
    """A variant's planner parameters, and its perception (None: the scenario's)."""
    planner = dict(variant)
    return planner, planner.pop("perception", None)


def run_rows(path: Path, variant: str, planner: Mapping[str, Any], seeds: Sequence[int]) -> list[SuiteRow]:
    """Runs of one scenario with one planner variant (its `perception` key, if any, says what the planner
    sees), classified."""
    scenario = load_scenario(path)
    planner, asked = split_variant(planner)
    perception = run_perception(scenario, asked)
    cfg = resolve_planner(planner, scenario)
    limits = robot_limits(cfg)
    robot_radius = cfg["robot_radius"]
    table = run_batch(scenario, seeds, np.tile(robot_params(), (len(seeds), 1)), planner=cfg,
                      duration=TIME_LIMIT, perception=perception).table
    moving_target = scenario.target is not None and scenario.target.speed > 0.0
    rows = []
    for seed, z in zip(seeds, table, strict=True):
        collided = z[Z_COLLISIONS] > 0
        hit = int(z[Z_HIT_OBSTACLE])
        avoidable = None
        hit_id = -1
        if collided and hit >= 0:
            obstacle = vary(scenario, seed).obstacles[hit]
            hit_id = obstacle.id
            t, x, y, yaw, speed, yaw_rate = z[Z_DETECTED:Z_DETECTED + 6]
            avoidable = collision_avoidable((x, y, yaw, speed, yaw_rate), obstacle_path(scenario, seed, hit, t),
                                            obstacle.radius, robot_radius, limits)
        reached = not math.isnan(z[Z_REACHED_AT])
        rows.append(SuiteRow(
            scenario=scenario.name, variant=variant, seed=seed,
            outcome=classify(reached, collided, avoidable, bool(z[Z_FALLEN]), bool(z[Z_STUCK_AT_END]),
                             moving_target, z[Z_STUCK_STEPS] / PLANNER_RATE / max(z[Z_SIM_TIME], 1e-9)),
            time_to_reach_s=finite_or_none(z[Z_REACHED_AT]), collisions=int(z[Z_COLLISIONS]), hit_obstacle_id=hit_id,
            min_clearance_m=finite_or_none(z[Z_MIN_CLEARANCE]), fallen=bool(z[Z_FALLEN]),
            stuck_time_s=float(z[Z_STUCK_STEPS]) / PLANNER_RATE, pitch_abs_max_settled_rad=float(z[Z_PITCH_SETTLED]),
            final_distance_m=float(z[Z_FINAL_DISTANCE]), sim_time_s=float(z[Z_SIM_TIME]),
            torque_step_max_nm=float(z[Z_TORQUE_STEP_MAX]), perception=perception,
            tracking=tuple(float(v) for v in z[Z_TRACKING:Z_TRACKING + N_JUDGE]) if perception == "lidar" else (),
        ))
    return rows


def summarise(rows: Sequence[SuiteRow]) -> dict[str, Any]:
    """One scenario and variant: success, each outcome's count, time to reach and clearance."""
    n = len(rows)
    reach = np.array([r.time_to_reach_s for r in rows if r.time_to_reach_s is not None and r.succeeded])
    clearance = [r.min_clearance_m for r in rows if r.min_clearance_m is not None]
    return {
        "runs": n,
        "success_rate": sum(r.succeeded for r in rows) / n,
        **{outcome: sum(r.outcome == outcome for r in rows) for outcome in OUTCOMES},
        "collided": sum(r.collisions > 0 for r in rows),
        "stuck": sum(r.stuck_time_s > 0 for r in rows),
        "time_to_reach_median_s": float(np.median(reach)) if len(reach) else None,
        "time_to_reach_p95_s": float(np.percentile(reach, 95)) if len(reach) else None,
        "min_clearance_m": min(clearance) if clearance else None,
        "pitch_abs_max_settled_rad": max(r.pitch_abs_max_settled_rad for r in rows),
        "torque_step_max_nm": max(r.torque_step_max_nm for r in rows),
        "tracking": tracking_figures(rows),
    }


def tracking_figures(rows: Sequence[SuiteRow]) -> dict[str, Any] | None:
    """The tracker's figures over the runs on the LiDAR (their sums pooled: evaluation.TrackingFigures)."""
    judged = [r.tracking for r in rows if r.tracking]
    return TrackingFigures.of(np.sum(judged, axis=0), SCAN_PERIOD).as_dict() if judged else None


def _cell(value: Any, fmt: str = "{:.1f}") -> str:
    return "–" if value is None else fmt.format(value)


def markdown_table(summary: Mapping[str, Mapping[str, Mapping[str, Any]]], variants: Sequence[str]) -> str:
    """One row per scenario and variant."""
    lines = ["| scenario | planner | success | collisions (avoidable / not) | falls | trapped | outrun | late |"
             " runs with time stuck | time to reach median / p95 [s] | min clearance [m] | max abs pitch after 2 s"
             " [rad] | largest torque step [N·m] |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for scenario, by_variant in summary.items():
        for variant in variants:
            s = by_variant.get(variant)
            if s is None:
                continue
            lines.append(
                f"| {scenario} | {variant} | {100 * s['success_rate']:.1f} % | {s['collided']}"
                f" ({s['collision_avoidable']} / {s['collision_unavoidable']}) | {s['fall']} | {s['trapped']} |"
                f" {s['outrun']} | {s['late']} | {s['stuck']} | {_cell(s['time_to_reach_median_s'])} /"
                f" {_cell(s['time_to_reach_p95_s'])} | {_cell(s['min_clearance_m'], '{:.2f}')} |"
                f" {s['pitch_abs_max_settled_rad']:.4f} | {_cell(s.get('torque_step_max_nm'), '{:.3f}')} |")
    return "\n".join(lines) + "\n"


def tracking_table(summary: Mapping[str, Mapping[str, Mapping[str, Any]]], variants: Sequence[str]) -> str:
    """The tracker's figures per scenario and variant on the LiDAR (none: "")."""
    lines = ["| scenario | planner | position RMSE [m] | velocity RMSE [m/s] | ID switches per 100 track-s |"
             " missed [%] | false tracks [%] | judged |", "|---|---|---|---|---|---|---|---|"]
    for scenario, by_variant in summary.items():
        for variant in variants:
            f = (by_variant.get(variant) or {}).get("tracking")
            if f is None:
                continue
            lines.append(
                f"| {scenario} | {variant} | {_cell(f['position_rmse_m'], '{:.3f}')} |"
                f" {_cell(f['velocity_rmse_mps'], '{:.3f}')} | {_cell(f['id_switches_per_100_track_s'], '{:.2f}')} |"
                f" {_cell(f['missed_pct'])} | {_cell(f['false_pct'])} | {f['judged']} |")
    return "\n" + "\n".join(lines) + "\n" if len(lines) > 2 else ""


def success_table(summary: Mapping[str, Mapping[str, Mapping[str, Any]]], variants: Sequence[str]) -> str:
    """Success per scenario (columns: variants), "av." = avoidable collisions; the mean over scenarios and
    the avoidable collisions over all of them in the last two rows: the ablation's table."""
    lines = [f"| scenario | {' | '.join(variants)} |", "|---" * (len(variants) + 1) + "|"]
    for scenario, by_variant in summary.items():
        cells = []
        for v in variants:
            s = by_variant[v]
            avoidable = f" ({s['collision_avoidable']} av.)" if s["collision_avoidable"] else ""
            cells.append(f"{100 * s['success_rate']:.1f} %{avoidable}")
        lines.append(f"| {scenario} | {' | '.join(cells)} |")
    means = [100 * float(np.mean([by[v]["success_rate"] for by in summary.values()])) for v in variants]
    avoidable = [sum(by[v]["collision_avoidable"] for by in summary.values()) for v in variants]
    lines.append("| **mean** | " + " | ".join(f"**{m:.2f} %**" for m in means) + " |")
    lines.append("| avoidable collisions (all) | " + " | ".join(str(a) for a in avoidable) + " |")
    return "\n".join(lines) + "\n"


def scenario_figure(path: Path, variants: Mapping[str, Mapping[str, Any]], out: Path) -> None:
    """The field of the first seed's layout at t = 0 and the first seeds' paths of each variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from twbr_planner.apf import Obstacles, potential

    scenario = load_scenario(path)
    seeds = list(range(1, TRACED_SEEDS + 1))
    fig, axes = plt.subplots(1, len(variants), figsize=(6.5 * len(variants), 6), squeeze=False)
    for ax, (variant, chosen) in zip(axes[0], variants.items(), strict=True):
        planner, asked = split_variant(chosen)
        cfg = resolve_planner(planner, scenario)
        result = run_batch(scenario, seeds, np.tile(robot_params(), (len(seeds), 1)), planner=cfg,
                           duration=TIME_LIMIT, record=True, perception=run_perception(scenario, asked))
        layout = vary(scenario, seeds[0])
        xs = [layout.start_x] + [o.x for o in layout.obstacles] + ([layout.target.x] if layout.target else [])
        ys = [layout.start_y] + [o.y for o in layout.obstacles] + ([layout.target.y] if layout.target else [])
        paths = [result.trace(i) for i in range(len(seeds))]
        xs += [float(v) for p in paths for v in (p["x_c"].min(), p["x_c"].max())]
        ys += [float(v) for p in paths for v in (p["y_c"].min(), p["y_c"].max())]
        lo_x, hi_x, lo_y, hi_y = min(xs) - 2, max(xs) + 2, min(ys) - 2, max(ys) + 2
        gx, gy = np.meshgrid(np.linspace(lo_x, hi_x, 160), np.linspace(lo_y, hi_y, 160))
        obstacles = Obstacles.of([(o.id, o.x, o.y, o.radius) for o in layout.obstacles])
        field_cfg = dict(cfg)
        if cfg["method"] == "robust":
            field_cfg["rho_o"] = cfg["repulsion_range"]  # the range the robust repulsion acts within
        u = potential(np.stack([gx, gy], axis=-1), np.array([layout.target.x, layout.target.y]), obstacles, field_cfg)
        ax.contourf(gx, gy, np.log1p(u), levels=30, cmap="viridis", alpha=0.8)
        for o in layout.obstacles:
            ax.add_patch(plt.Circle((o.x, o.y), o.radius, color="0.3", alpha=0.7))
            if o.vx or o.vy:
                ax.arrow(o.x, o.y, 3 * o.vx, 3 * o.vy, width=0.05, color="orange")
        for i, p in enumerate(paths):
            ax.plot(p["x_c"], p["y_c"], lw=1.2, color=plt.cm.autumn(i / max(1, len(paths) - 1)),
                    label=f"seed {seeds[i]}" if i < 3 else None)
        ax.plot(layout.target.x, layout.target.y, "r*", ms=14)
        ax.plot(layout.start_x, layout.start_y, "wo", ms=6)
        ax.set_xlim(lo_x, hi_x)
        ax.set_ylim(lo_y, hi_y)
        ax.set_aspect("equal")
        ax.set_title(f"{scenario.name}: {variant} (field and obstacles of seed 1 at t = 0)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def run_suite(out_dir: Path, runs: int, variants: Mapping[str, Mapping[str, Any]], paths: Iterable[Path],
              figures: bool = True, progress: bool = True, first_seed: int = 1) -> dict[str, Any]:
    """Every scenario for every variant, seeds first_seed..first_seed + runs - 1; rows appended to runs.csv
    as each chunk ends."""
    out_dir.mkdir(parents=True, exist_ok=True)
    seeds = list(range(first_seed, first_seed + runs))
    summary: dict[str, dict[str, Any]] = {}
    started = time.monotonic()
    with (out_dir / "runs.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        for path in paths:
            name = path.stem if path.stem not in summary else str(path)  # a user's file named like a suite one
            summary[name] = {}
            for variant, planner in variants.items():
                rows: list[SuiteRow] = []
                for k in range(0, len(seeds), CHUNK):
                    chunk = run_rows(path, variant, planner, seeds[k:k + CHUNK])
                    writer.writerows(csv_row(r) for r in chunk)
                    f.flush()
                    rows += chunk
                summary[name][variant] = summarise(rows)
                if progress:
                    s = summary[name][variant]
                    print(f"suite: {name:26s} {variant:22s} success {100 * s['success_rate']:5.1f} %"
                          f" ({time.monotonic() - started:.0f} s)", file=sys.stderr, flush=True)
            if figures:
                (out_dir / "figures").mkdir(exist_ok=True)
                scenario_figure(path, {v: variants[v] for v in list(variants)[:2]}, out_dir / "figures" / f"{name}.png")
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    (out_dir / "table.md").write_text(markdown_table(summary, list(variants)) + tracking_table(summary, list(variants)))
    return summary


def with_perceptions(variants: Mapping[str, Mapping[str, Any]], text: str | None) -> dict[str, dict[str, Any]]:
    """The variants on each perception `text` names ("truth", "lidar" or both, comma-separated); one: the
    variants' names kept, two: "<variant>" on the truth and "<variant> lidar"."""
    if text is None:
        return {name: dict(v) for name, v in variants.items()}
    chosen = [p.strip() for p in text.split(",") if p.strip()]
    if not chosen or any(p not in PERCEPTIONS for p in chosen) or len(set(chosen)) < len(chosen):
        raise ConfigError(f"invalid --perception {text!r}: must be truth, lidar or truth,lidar")
    both = len(chosen) > 1
    return {(f"{name} {p}" if both and p != "truth" else name): {**v, "perception": p}
            for p in chosen for name, v in variants.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="suite", description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", "--runs", type=int, default=1000, help="seeds per scenario and method (default 1000)")
    ap.add_argument("--first-seed", type=int, default=1,
                    help="the first seed (default 1); another range checks results on seeds nothing was tuned on")
    ap.add_argument("--methods", default=",".join(METHODS), help="planner methods, comma-separated (default: all)")
    ap.add_argument("--ablation", action="store_true",
                    help="the robust method with each addition switched off in turn, instead of the methods")
    ap.add_argument("--scenarios", help="only these scenarios, comma-separated: suite names (gap_1m), installed"
                    " names (static, suite/gap_1m) or your own scenario files")
    ap.add_argument("--perception", help="what the planner sees: truth, lidar, or truth,lidar for both side by"
                    " side (default: each scenario's own, lidar but for the paper's three)")
    ap.add_argument("--out", type=Path, default=Path("runs") / "suite")
    ap.add_argument("--no-figures", action="store_true")
    opts = ap.parse_args(argv)
    try:
        if opts.runs < 1:
            raise ConfigError(f"invalid --runs {opts.runs}: must be at least 1")
        if opts.first_seed < 0:
            raise ConfigError(f"invalid --first-seed {opts.first_seed}: must be at least 0")
        if opts.ablation:
            variants = ablation_variants()
        else:
            methods = [m.strip() for m in opts.methods.split(",") if m.strip()]
            unknown = [m for m in methods if m not in METHODS]
            if unknown or not methods:
                raise ConfigError(f"invalid --methods {opts.methods!r}: must be some of {', '.join(METHODS)}")
            variants = {m: {"method": m} for m in methods}
        variants = with_perceptions(variants, opts.perception)
        paths = chosen_scenarios(opts.scenarios) if opts.scenarios else suite_scenarios()
    except ConfigError as e:
        print(f"suite: {e}", file=sys.stderr)
        return 2
    print(f"suite: {len(paths)} scenarios x {len(variants)} planners x {opts.runs} seeds from {opts.first_seed}"
          f" -> {opts.out}", flush=True)
    summary = run_suite(opts.out, opts.runs, variants, paths, figures=not opts.no_figures,
                        first_seed=opts.first_seed)
    print(markdown_table(summary, list(variants)) + tracking_table(summary, list(variants)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
