"""Step-response and settling figures from sampled signals (numpy only).

Shared by the metrics of a recorded run, the tuner's cost and the tests, so that "settles within
1.5 s" means the same thing everywhere.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

PITCH_BAND = 0.005  # [rad] "theta returns within +-0.005 rad of its equilibrium": the pitch's settling band


@dataclass(frozen=True)
class StepResponse:
    step_time_s: float  # when the reference stepped
    initial: float  # reference before the step
    final: float  # reference after the step
    settle_time_s: float  # from the step until the output stays inside the band (inf: never)
    overshoot_pct: float  # past the final value, in % of the step size (>= 0)
    undershoot: float  # most the output went the wrong way first (non-minimum phase), in output units
    steady_state_error_pct: float  # |mean over the last tail - final| in % of the step size
    band: float  # the settling band, in output units

    def as_dict(self) -> dict[str, float]:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}


def settle_time(t: np.ndarray, y: np.ndarray, target: float, band: float, start: float) -> float:
    """Time from `start` after which |y - target| <= band until the end of the samples (inf: never)."""
    after = t >= start - 1e-12
    outside = after & (np.abs(y - target) > band)
    if not outside.any():
        return 0.0
    last_out = int(np.flatnonzero(outside)[-1])
    if last_out + 1 >= len(t):
        return math.inf
    return float(t[last_out + 1] - start)


def step_times(t: np.ndarray, ref: np.ndarray, threshold: float = 1e-9) -> np.ndarray:
    """Times at which the reference changes."""
    changes = np.flatnonzero(np.abs(np.diff(ref)) > threshold) + 1
    return t[changes]


def step_response(
    t: np.ndarray,
    y: np.ndarray,
    ref: np.ndarray,
    band_fraction: float = 0.05,
    tail_s: float = 0.5,
) -> StepResponse | None:
    """Figures of the first reference step and the response until the next step or the end."""
    steps = step_times(t, ref)
    if len(steps) == 0:
        return None
    t0 = steps[0]
    end = steps[1] if len(steps) > 1 else math.inf
    i0 = int(np.searchsorted(t, t0 - 1e-12))
    initial = float(ref[i0 - 1]) if i0 > 0 else 0.0
    final = float(ref[i0])
    size = final - initial
    seg = (t >= t0 - 1e-12) & (t < end - 1e-12)
    ts, ys = t[seg], y[seg]
    band = band_fraction * abs(size)
    direction = math.copysign(1.0, size)
    overshoot = max(0.0, float(np.max((ys - final) * direction))) / abs(size) * 100.0
    undershoot = max(0.0, float(np.max((initial - ys) * direction)))
    tail = ts >= ts[-1] - tail_s
    sse = abs(float(np.mean(ys[tail])) - final) / abs(size) * 100.0
    return StepResponse(
        step_time_s=float(t0), initial=initial, final=final,
        settle_time_s=settle_time(ts, ys, final, band, t0), overshoot_pct=overshoot, undershoot=undershoot,
        steady_state_error_pct=sse, band=band,
    )
