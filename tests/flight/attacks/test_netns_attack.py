"""One attacker in a network namespace of its own, reaching the vehicle over a veth pair, as on a real network.

Skipped cleanly where the machine does not allow it (not root, no ``ip``, no namespaces). The pair's addresses
are a private /30 that exists only between this process's namespace and the attacker's, for the test's length.
"""

import os
import shutil
import subprocess
import sys
import textwrap
import uuid

import pytest

from flight.mavlink import MavlinkVehicle
from flight.signing import new_key
from flight.sim import Simulator
from tests.waiting import wait_for

ATTACK = textwrap.dedent(
    """
    import os, socket, sys
    os.environ["MAVLINK20"] = "1"
    from pymavlink.dialects.v20 import common as m
    host, port, wrong_key = sys.argv[1], int(sys.argv[2]), bytes.fromhex(sys.argv[3])
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    plain = m.MAVLink(None, srcSystem=255, srcComponent=190)
    forged = m.MAVLink(None, srcSystem=255, srcComponent=190)
    forged.signing.secret_key, forged.signing.sign_outgoing, forged.signing.link_id = wrong_key, True, 3
    for mav in (plain, forged):
        for _ in range(3):
            arm = mav.command_long_encode(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
            sock.sendto(arm.pack(mav), (host, port))
            mav.seq = (mav.seq + 1) % 256
    """
)


def _ip(*args, check=True):
    return subprocess.run(["ip", *args], check=check, capture_output=True, text=True, timeout=10)


@pytest.fixture
def namespace():
    if os.geteuid() != 0 or shutil.which("ip") is None:
        pytest.skip("network namespaces need root and iproute2")
    tag = uuid.uuid4().hex[:6]
    ns, host_if, ns_if = f"agu-{tag}", f"agu{tag}h", f"agu{tag}n"
    net = f"10.{200 + int(tag[:2], 16) % 50}.{int(tag[2:4], 16)}"
    try:
        _ip("netns", "add", ns)
    except (subprocess.CalledProcessError, OSError) as exc:
        pytest.skip(f"cannot make a network namespace here: {exc}")
    try:
        _ip("link", "add", host_if, "type", "veth", "peer", "name", ns_if)
        _ip("link", "set", ns_if, "netns", ns)
        _ip("addr", "add", f"{net}.1/30", "dev", host_if)
        _ip("link", "set", host_if, "up")
        _ip("netns", "exec", ns, "ip", "addr", "add", f"{net}.2/30", "dev", ns_if)
        _ip("netns", "exec", ns, "ip", "link", "set", ns_if, "up")
        _ip("netns", "exec", ns, "ip", "link", "set", "lo", "up")
        yield ns, f"{net}.1"
    except subprocess.CalledProcessError as exc:
        pytest.skip(f"cannot wire the namespace: {exc.stderr.strip()}")
    finally:
        _ip("link", "del", host_if, check=False)
        _ip("netns", "del", ns, check=False)


def test_an_attacker_in_another_namespace_is_refused_and_counted(namespace):
    ns, vehicle_ip = namespace
    with MavlinkVehicle(Simulator(seed=1), gcs=None, api=None, bind=(vehicle_ip, 0), signing_key=new_key()) as v:
        v.start(speed=1.0)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
        attack = subprocess.run(
            ["ip", "netns", "exec", ns, sys.executable, "-c", ATTACK, vehicle_ip, str(v.address[1]), new_key().hex()],
            capture_output=True, text=True, timeout=60, env=env,
        )  # fmt: skip
        assert attack.returncode == 0, attack.stderr
        wait_for(lambda: v.security()["unsigned"] >= 3 and v.security()["bad_signature"] >= 3, 10.0, what="refusals")
        assert not v.sim.armed and v.security()["signed"] == 0 and v.peers == []
