"""The vehicle's guard on its links: MAVLink 2 signing (PX4's semantics), and what only a signed link may do in the air.

Why: anyone who can send the vehicle a datagram must not be able to command it. :class:`LinkGuard` judges every
received frame with a :class:`~flight.signing.Signer` and counts what it refused; it answers SETUP_SIGNING and keeps
the key where PX4 keeps it (a 40-byte key store, mode 0600); and it says which safety parameters and which forced
disarm need an *authenticated* message (one signed with the key) while the vehicle is armed.

Behaviour (PX4's "MAVLink Message Signing" page, read for this), and ours where it differs:

* No key: everything is accepted, unless signing is *required* (ours: ``--signing-key``, a run's own vehicle, or
  ``require_signing``): then only HEARTBEAT and the other unsigned-allowed messages are taken, and commands are
  refused (counted as ``no_key``) rather than obeyed; a SETUP_SIGNING may still provision a key, on the ground.
* With a key: outgoing frames are signed; incoming ones must be signed with it and fresh (replay window per
  stream), except HEARTBEAT, RADIO_STATUS, ADSB_VEHICLE and COLLISION. An unsigned heartbeat keeps nothing alive
  here: it neither makes nor feeds the commanding ground station.
* SETUP_SIGNING (256), addressed to us or broadcast: refused while armed; with a key, it must be signed with it;
  an all-zero key with a zero timestamp turns signing off; any other key replaces the old one and is stored.
* Ours, not PX4's: while armed, the safety parameters (:func:`is_safety_param`: fence ``GF_*``, failsafes
  ``NAV_*``, ``COM_*``, ``BAT_*``, and ``SYS_FAILURE_EN``) can be changed only by a signed PARAM_SET, the fence
  plan (mission type FENCE) replaced or cleared only by signed messages (counted with the parameters), and a
  forced disarm in the air (COMPONENT_ARM_DISARM with 21196) needs a signed command. Without signing nobody can.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20.common import MAV_SEVERITY_INFO, MAV_SEVERITY_WARNING  # MAVLink's own constants

from flight.signing import KEY_LEN, KeyStore, Signer, Verdict

SAFETY_PREFIXES = ("GF_", "NAV_", "COM_", "BAT_")
SAFETY_PARAMS = frozenset({"SYS_FAILURE_EN"})

Notify = Callable[[str, int], None]


def is_safety_param(name: str) -> bool:
    """Whether ``name`` is a fence or failsafe parameter (locked in the air but for a signed link).

    >>> is_safety_param("GF_MAX_HOR_DIST"), is_safety_param("NAV_DLL_ACT"), is_safety_param("MIS_TAKEOFF_ALT")
    (True, True, False)
    """
    return name.startswith(SAFETY_PREFIXES) or name in SAFETY_PARAMS


class LinkGuard:
    """Signing and the armed-vehicle rules for one vehicle (see the module docstring)."""

    def __init__(
        self,
        *,
        key: bytes | None = None,
        key_store: str | Path | None = None,
        required: bool | None = None,
        notify: Notify = lambda text, severity: None,
    ) -> None:
        self.store = KeyStore(key_store) if key_store is not None else None
        stored = self.store.load() if self.store is not None else None
        timestamp = 0
        if key is None and stored is not None:
            key, timestamp = stored
        elif key is not None and self.store is not None:
            self.store.save(key, timestamp)
        self.signer = Signer(key, required=bool(key is not None if required is None else required), timestamp=timestamp)
        self.notify = notify
        self.in_hand_signed = True
        """Whether the message being handled was signed with the key (True for calls made in this process)."""
        self.refused_params = 0
        self.refused_disarms = 0
        self.refused_setup = 0

    @property
    def active(self) -> bool:
        return self.signer.active

    def judge(self, msg: Any, *, armed: bool) -> Verdict:
        """Whether to take ``msg`` (counted by reason); a key may be provisioned on the ground only."""
        return self.signer.check(msg, provisioning=not armed)

    def setup_signing(self, msg: Any, *, armed: bool) -> None:
        """SETUP_SIGNING, already judged acceptable and addressed to us."""
        if armed:
            self.refused_setup += 1
            self.notify("Signing change denied: vehicle is armed", MAV_SEVERITY_WARNING)
            return
        if self.signer.active and not self.in_hand_signed:
            self.refused_setup += 1
            self.notify("Signing change denied: not signed with the current key", MAV_SEVERITY_WARNING)
            return
        key = bytes(msg.secret_key)
        timestamp = int(msg.initial_timestamp)
        if len(key) != KEY_LEN:
            self.refused_setup += 1
            return
        if key == bytes(KEY_LEN) and timestamp == 0:
            self.signer.set_key(None)
            if self.store is not None:
                self.store.save(None, 0)
            self.notify("Signing disabled", MAV_SEVERITY_INFO)
            return
        self.signer.set_key(key, timestamp)
        if self.store is not None:
            self.store.save(key, self.signer.state.timestamp)
        self.notify("Signing key set", MAV_SEVERITY_INFO)

    def may_set_param(self, name: str, *, armed: bool) -> bool:
        """Whether the PARAM_SET in hand may change ``name`` (counted when not)."""
        if armed and is_safety_param(name) and not self.in_hand_signed:
            self.refused_params += 1
            return False
        return True

    def fence_plan_locked(self, *, armed: bool) -> str | None:
        """Why the fence plan in hand may not be replaced or cleared now (None: it may; counted when not)."""
        if armed and not self.in_hand_signed:
            self.refused_params += 1
            return "Fence rejected: armed, and not from a signed link"
        return None

    def may_force_disarm(self, *, flying: bool) -> bool:
        """Whether the forced disarm in hand may cut the motors (counted when not)."""
        if flying and not self.in_hand_signed:
            self.refused_disarms += 1
            return False
        return True

    def report(self) -> dict[str, int]:
        """The guard's counters: the signing verdicts and the refusals of the armed-vehicle rules."""
        out = self.signer.counters.as_dict()
        out.update(
            refused_params=self.refused_params,
            refused_disarms=self.refused_disarms,
            refused_setup_signing=self.refused_setup,
        )
        return out


__all__ = ["SAFETY_PARAMS", "SAFETY_PREFIXES", "LinkGuard", "is_safety_param"]
