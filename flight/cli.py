"""``agentic-uav sim``: the simulated F450 as a PX4-like MAVLink vehicle on UDP, until Ctrl-C or SIGTERM.

Home is ``--home LAT,LON[,ALT]``, or a scene file's (``--scene FILE``), or the vehicle resumes a snapshot
(``--resume FILE``, what :meth:`flight.mavlink.MavlinkVehicle.snapshot` wrote). A bad home, scene or snapshot is
reported naming the file and the field, exit status 2.

It binds one UDP socket (``--bind``, by default 127.0.0.1:18570, the port PX4 SITL's ground-station link listens
on, from memory of PX4's ``px4-rc.mavlink``), streams to the ground-station and API addresses (``--gcs``
127.0.0.1:14550 and ``--api`` 127.0.0.1:14540, as PX4 SITL; ``none`` turns one off) and answers whoever talks
to it. ``--speed`` is a multiple of real time, or ``max`` for as fast as the machine goes. It prints where it
listens, then runs until interrupted, and stops cleanly (the socket closed, exit status 0).

``--sysid`` is its MAVLink system id (1 by default; PX4 SITL's instance ``i`` is ``i + 1``, with ``--bind`` port
18570+i and ``--api`` 127.0.0.1:14540+i): several vehicles, each its own process with its own ``--home``, make a
swarm that ``agentic-uav swarm run --connect`` tells apart by system id. ``--vehicles N`` serves N in this one
process on one clock with that numbering: vehicle ``i`` has system id ``--sysid`` + i, listens on the ``--bind``
port + i, streams to the ``--api`` port + i (the ground station is shared), and stands ``--spacing`` metres east of
the one before; it prints one line per vehicle.

>>> numbered(("127.0.0.1", 18570), 2), numbered(("127.0.0.1", 0), 2), numbered(None, 2)
(('127.0.0.1', 18572), ('127.0.0.1', 0), None)

>>> parse_speed("4"), parse_speed("max")
(4.0, None)
>>> parse_address("127.0.0.1:14550"), parse_address("none")
(('127.0.0.1', 14550), None)

Signing (MAVLink 2, :mod:`flight.mavlink.guard`): ``--signing-key FILE`` (32 raw bytes or 64 hex digits; a bad
file is an error naming it, exit status 2) makes the vehicle sign and take only messages signed with that key;
``--state-dir DIR`` keeps a key set by SETUP_SIGNING across restarts, as PX4 keeps it
(``DIR/mavlink/mavlink-signing-key.bin``, mode 0600); ``--require-signing`` refuses commands while there is no key.
On stop it prints what the guard refused.

The first line on standard output says where it listens: ``agentic-uav sim: listening on HOST:PORT; ...``.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from flight.mavlink import VehicleSnapshot
    from flight.sim import Simulator

from agentic_core.contracts.errors import AgenticUAVError, report_error
from agentic_core.contracts.geodesy import offset_position

Address = tuple[str, int]

DEFAULT_BIND = "127.0.0.1:18570"
DEFAULT_GCS = "127.0.0.1:14550"
DEFAULT_API = "127.0.0.1:14540"
DEFAULT_HOME_ALT_MSL_M = 300.0
"""The simulator's default home elevation (:data:`flight.sim.environment.DEFAULT_HOME_ALT_MSL_M`), restated so
that parsing arguments does not import the simulator."""


def parse_speed(text: str) -> float | None:
    """``max`` (as fast as possible: None) or a positive multiple of real time."""
    if text.strip().lower() in ("max", "none", "fast"):
        return None
    try:
        speed = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"speed must be a positive number or 'max', not {text!r}") from None
    if not speed > 0 or speed == float("inf"):
        raise argparse.ArgumentTypeError(f"speed must be a positive number or 'max', not {text!r}")
    return speed


def parse_address(text: str) -> Address | None:
    """``HOST:PORT``, or ``none``/``off`` for no address."""
    if text.strip().lower() in ("none", "off", ""):
        return None
    host, sep, port = text.strip().rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT (or none), not {text!r}")
    return host, int(port)


def parse_home(text: str) -> tuple[float, float, float]:
    """``LAT,LON[,ALT]`` (degrees, degrees, metres above mean sea level; 300 m when left out).

    >>> parse_home("21.42,39.89"), parse_home("48.1, 11.5, 520")
    ((21.42, 39.89, 300.0), (48.1, 11.5, 520.0))
    """
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
        if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LAT,LON[,ALT] in degrees and metres, not {text!r}") from None
    lat, lon, alt = (*values, DEFAULT_HOME_ALT_MSL_M) if len(values) == 2 else values
    return lat, lon, alt


def parse_system_id(text: str) -> int:
    """A MAVLink system id, 1 to 255.

    >>> parse_system_id("3")
    3
    """
    if not text.strip().isdigit() or not 1 <= int(text) <= 255:
        raise argparse.ArgumentTypeError(f"a MAVLink system id is 1 to 255, not {text!r}")
    return int(text)


def numbered(address: Address | None, index: int) -> Address | None:
    """Vehicle ``index``'s address in PX4's multi-vehicle numbering: the port plus ``index`` (0, any port, stays)."""
    if address is None or address[1] == 0:
        return address
    return address[0], address[1] + index


def parse_param(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    try:
        return name.strip(), float(value) if sep else float("nan")
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, not {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="agentic-uav sim",
        description="Run the simulated F450 as a PX4-like MAVLink vehicle on UDP until Ctrl-C or SIGTERM.",
    )
    parser.add_argument("--speed", type=parse_speed, default=1.0, help="multiple of real time, or 'max' (default 1)")
    parser.add_argument("--gcs", type=parse_address, default=DEFAULT_GCS, help=f"ground station ({DEFAULT_GCS})")
    parser.add_argument("--api", type=parse_address, default=DEFAULT_API, help=f"API address ({DEFAULT_API})")
    parser.add_argument("--bind", type=parse_address, default=DEFAULT_BIND, help=f"listen here ({DEFAULT_BIND})")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--home", type=parse_home, default=None, help="LAT,LON[,ALT] of home (default: Mina, 300 m above sea level)"
    )
    where.add_argument("--scene", default=None, metavar="FILE", help="take home from this scene file (scenes/*.yaml)")
    where.add_argument(
        "--resume", default=None, metavar="FILE", help="start from a vehicle snapshot (JSON, MavlinkVehicle.snapshot)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the wind gusts and GPS noise")
    parser.add_argument(
        "--vehicles", type=parse_system_id, default=1, help="serve N vehicles on one clock (PX4's numbering, above)"
    )
    parser.add_argument("--spacing", type=float, default=20.0, help="metres east between --vehicles' homes (20)")
    parser.add_argument(
        "--sysid", type=parse_system_id, default=1, help="MAVLink system id (PX4's multi-vehicle: instance i is i+1)"
    )
    parser.add_argument(
        "--gains", default=None, metavar="FILE", help="position-controller gains: tune.json of agentic-uav eval tune"
    )
    parser.add_argument(
        "--param", type=parse_param, action="append", default=[], metavar="NAME=VALUE", help="a vehicle parameter"
    )
    parser.add_argument(
        "--signing-key", default=None, metavar="FILE", help="MAVLink 2 signing key: 32 raw bytes or 64 hex digits"
    )
    parser.add_argument(
        "--state-dir", default=None, metavar="DIR", help="keep a key set by SETUP_SIGNING here (as PX4 does)"
    )
    parser.add_argument(
        "--require-signing", action="store_true", default=None, help="refuse commands while there is no key"
    )
    return parser


def _simulator(args: argparse.Namespace, east_m: float = 0.0) -> tuple[Simulator, VehicleSnapshot | None]:
    """The simulator the arguments ask for, its home ``east_m`` east of theirs, and the snapshot to resume
    (ValueError naming what is wrong)."""
    from flight.mavlink import VehicleSnapshot
    from flight.sim import Environment, Home, Simulator
    from flight.sim.gains_file import load_gains
    from flight.sim.scene_file import load_scene

    gains = load_gains(args.gains) if args.gains is not None else None
    if args.resume is not None:
        try:
            text = Path(args.resume).read_text(encoding="utf-8")
        except OSError as exc:
            raise ValueError(f"cannot read the snapshot {args.resume}: {exc.strerror or exc}") from None
        return Simulator(seed=args.seed, gains=gains), VehicleSnapshot.from_json(text, file=args.resume)
    if args.scene is not None:
        if not Path(args.scene).is_file():
            raise ValueError(f"no scene file {args.scene}")
        home = load_scene(args.scene).home.to_home()
    else:
        home = Home(*args.home) if args.home else Home()
    if east_m:
        lat, lon = offset_position(home.lat_deg, home.lon_deg, 0.0, east_m)
        home = Home(lat_deg=lat, lon_deg=lon, alt_msl_m=home.alt_msl_m, heading_deg=home.heading_deg)
    return Simulator(Environment(home=home), seed=args.seed, gains=gains), None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the vehicle until SIGINT or SIGTERM; 0 after a clean stop, 1 when it cannot start or fails, 2 on bad
    input."""
    try:
        return _main(argv)
    except AgenticUAVError as exc:
        return report_error("agentic-uav sim", exc, sys.stderr)


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.bind is None:
        print("agentic-uav sim: error: --bind needs an address", file=sys.stderr)
        return 2

    if args.vehicles > 1 and (args.resume is not None or args.state_dir is not None):
        print("agentic-uav sim: error: --vehicles starts fresh vehicles; --resume and --state-dir are for one",
              file=sys.stderr)  # fmt: skip
        return 2
    if args.sysid + args.vehicles - 1 > 255:
        print(f"agentic-uav sim: error: system ids {args.sysid} to {args.sysid + args.vehicles - 1}: at most 255",
              file=sys.stderr)  # fmt: skip
        return 2

    from flight.mavlink import MavlinkVehicle
    from flight.mavlink.lockstep import Lockstep
    from flight.signing import read_key_file

    key = read_key_file(args.signing_key) if args.signing_key is not None else None
    store = Path(args.state_dir) / "mavlink" / "mavlink-signing-key.bin" if args.state_dir is not None else None
    try:
        sims = [_simulator(args, east_m=i * args.spacing) for i in range(args.vehicles)]
    except ValueError as exc:  # a bad home, scene or snapshot: the user's input
        print(f"agentic-uav sim: error: {exc}", file=sys.stderr)
        return 2
    fleet: list[MavlinkVehicle] = []
    try:
        for i, (sim, _) in enumerate(sims):
            fleet.append(MavlinkVehicle(
                sim, gcs=args.gcs, api=numbered(args.api, i), bind=numbered(args.bind, i) or args.bind,
                system_id=args.sysid + i, params=dict(args.param), signing_key=key, key_store=store,
                require_signing=args.require_signing,
            ))  # fmt: skip
    except AgenticUAVError:
        for vehicle in fleet:
            vehicle.close()
        raise
    except (OSError, ValueError) as exc:
        for vehicle in fleet:
            vehicle.close()
        print(f"agentic-uav sim: error: {exc}", file=sys.stderr)
        return 1
    snapshot = sims[0][1]
    if snapshot is not None:
        try:
            fleet[0].restore(snapshot)
        except ValueError as exc:
            fleet[0].close()
            print(f"agentic-uav sim: error: {args.resume}: {exc}", file=sys.stderr)
            return 2

    stop = threading.Event()

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous: dict[int, object] = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, on_signal)
    clock = Lockstep(fleet) if len(fleet) > 1 else None
    try:
        thread = clock.start(args.speed) if clock is not None else fleet[0].start(args.speed)
        speed = "max" if args.speed is None else f"{args.speed:g}x"
        for i, vehicle in enumerate(fleet):
            host, port = vehicle.address
            sends = (("gcs", args.gcs), ("api", numbered(args.api, i)))
            targets = ", ".join(f"{name} {a[0]}:{a[1]}" for name, a in sends if a)
            guard = vehicle.guard
            signing = "on" if guard.active else "required, no key" if guard.signer.required else "off"
            print(
                f"agentic-uav sim: listening on {host}:{port}; system id {vehicle.system_id}; "
                f"sending to {targets or 'nobody until contacted'}; "
                f"speed {speed}; signing {signing}; Ctrl-C or SIGTERM stops it",
                flush=True,
            )
        while not stop.wait(0.2):
            if not thread.is_alive():
                print("agentic-uav sim: error: the vehicle stopped unexpectedly", file=sys.stderr)
                return 1
        return 0
    finally:
        if clock is not None:
            clock.stop()
        for vehicle in fleet:
            vehicle.close()
        for signum, handler in previous.items():
            with contextlib.suppress(TypeError, ValueError):
                signal.signal(signum, handler)  # type: ignore[arg-type]
        if stop.is_set():
            refused: dict[str, int] = {}
            for vehicle in fleet:
                for k, v in vehicle.security().items():
                    if v and k not in ("signed", "allowed_unsigned"):
                        refused[k] = refused.get(k, 0) + v
            print(f"agentic-uav sim: stopped; refused {refused or 'nothing'}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
