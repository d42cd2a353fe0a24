"""How fast the simulated F450 runs, in simulated seconds per wall-clock second.

Cases, in one run:

* (a) bare JSBSim: the F450 model stepped at 250 Hz with a fixed hover throttle, no Python above it;
* (b) our simulator: JSBSim plus the 50 Hz flight controller, battery, gusts and GPS noise, taking off and holding
  a hover (with a 3 m/s gusty wind so the controller has work to do);
* (c) the MAVLink vehicle with a client streaming telemetry — not built yet; reported as pending.

Each case is timed ``--repeats`` times over ``--seconds`` of simulated flight and the best run is reported, with the
ratio (b)/(a). Usage: ``python benchmarks/sim_speed.py [--seconds 60] [--repeats 3] [--quick]``. Exit status 0.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from flight.sim import F450Model, Simulator, WindSettings  # noqa: E402
from flight.sim.jsbsim_model import DT, HOVER_THROTTLE  # noqa: E402

TABLE_HEADER = "simulator speed benchmark"


def bare_jsbsim(seconds: float) -> float:
    model = F450Model(21.4133, 39.8933, 300.0)
    model.set_engaged(True)
    model.set_controls(HOVER_THROTTLE, 0.0, 0.0, 0.0)
    steps = round(seconds / DT)
    t0 = time.perf_counter()
    model.step(steps)
    return seconds / (time.perf_counter() - t0)


def with_controller(seconds: float) -> float:
    sim = Simulator(seed=1)
    sim.set_wind(WindSettings(east_mps=3.0, gust_std_mps=1.0))
    sim.arm()
    sim.takeoff(10.0)
    t0 = time.perf_counter()
    sim.run_for(seconds)
    return seconds / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="10 s, one repeat (smoke test)")
    args = parser.parse_args(argv)
    seconds, repeats = (10.0, 1) if args.quick else (args.seconds, args.repeats)

    a = max(bare_jsbsim(seconds) for _ in range(repeats))
    b = max(with_controller(seconds) for _ in range(repeats))
    print(TABLE_HEADER)
    print(f"{seconds:g} simulated seconds per run, best of {repeats}; physics at 250 Hz")
    print(f"{'case':<44} {'sim s / wall s':>15}")
    print(f"{'(a) bare JSBSim F450':<44} {a:>14.0f}x")
    print(f"{'(b) simulator + controller (50 Hz)':<44} {b:>14.0f}x")
    print(f"{'(c) MAVLink vehicle + telemetry client':<44} {'pending':>15}")
    print(f"ratio (b)/(a): {b / a:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
