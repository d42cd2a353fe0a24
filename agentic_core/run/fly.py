"""A run flown, from the vehicle reached to the report: the vehicle reached and handed the mission's limits, the
mission compiled onto the graph and streamed under the :class:`~agentic_core.agent.AgentLoop` (from its checkpoint when
resumed), a stop or the wall-clock limit carried out, every critical event's answer and the aircraft's end checked for
the outcome, the run released, the report written. :meth:`~agentic_core.run.runner.MissionRun.execute` is
:func:`fly`."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from ..agent import AgentLoop
from ..agent.envelope import FLOOR_M
from ..contracts import AgenticUAVError, InputError, RunFailure
from ..contracts.policy_graph import Circle
from ..graph.checkpoint.sqlite import SqliteSaver
from ..mission import compile_mission, initial_state
from .assembly import setup_frozen
from .report import write_report
from .run_memory import start_memory
from .settings import RunResult
from .stand_down import stand_down
from .state_files import RunRecord, write_record
from .stops import STOP_OUTCOMES, carry_out, go_back
from .summary import summarise
from .vehicle_lost import check_end

if TYPE_CHECKING:
    from .runner import MissionRun

DEFAULT_CEILING_M = 120.0
"""The ceiling handed to the vehicle with a fence when the mission names none (a common legal limit)."""


def reach_vehicle(run: MissionRun) -> None:
    """Connect to the vehicle before anything flies; :class:`RunFailure` when it does not answer."""
    status = run.executor.call("flight.status", {})
    if status.status == "denied":  # the mission's scopes leave out flight:read (load refuses such missions)
        raise InputError(f"the agent may not read the vehicle ({status.error}): the scopes need flight:read")
    if status.status != "ok":
        raise RunFailure(f"cannot reach the vehicle at {run.backend.address}: {status.error}")


def fence_vehicle(run: MissionRun) -> None:
    """Hand the vehicle the mission's limits before take-off (fence items, ceiling, floor, return altitude under
    the ceiling), so it enforces them itself, PX4's way; :class:`RunFailure` when it does not take them."""
    limits = run.plan.limits
    if limits.geofence is None and limits.max_altitude_m is None:
        return
    args: dict[str, Any] = {"max_alt_m": limits.max_altitude_m or DEFAULT_CEILING_M, "floor_m": FLOOR_M}
    fence = limits.geofence
    if isinstance(fence, Circle):
        args.update(center={"lat": fence.center.lat, "lon": fence.center.lon}, radius_m=fence.radius_m)
    elif fence is not None:
        args["polygon"] = [{"lat": p.lat, "lon": p.lon} for p in fence]
    result = run.dispatch.call("flight.set_fence", args)
    if result.status != "ok":
        raise RunFailure(f"the vehicle did not take the mission's limits: {result.error}")


def fly(run: MissionRun) -> RunResult:
    """Fly ``run``'s mission (or go on with it); always releases the vehicle and writes the report."""
    wall0 = time.monotonic()
    if not run.resuming:
        write_record(run.run_dir, RunRecord(run_id=run.run_id, settings=run.settings))
    run.bus.publish("run", event="resume" if run.resuming else "start", mission=str(run.settings.mission),
                    reasoner=run.reasoner.name, backend=run.backend.kind,
                    summary=f"{'resume' if run.resuming else 'start'} {run.plan.plan_id} "
                    f"with {run.reasoner.name} on {run.backend.kind}")  # fmt: skip
    if run.model_note:
        run.bus.publish("log", level="warning", summary=run.model_note)
    start_memory(run.memory, run.plan.knowledge, run.bus, run.home)  # or say knowledge goes unread
    final: dict[str, Any] = {}
    outcome = "failed"
    try:
        run.backend.start()
        run.failsafes.start()
        run.faults.start()
        reach_vehicle(run)
        fence_vehicle(run)
        run.prepare()
        if run.resuming:
            go_back(run.trace.records, run.view(), run.dispatch.call, run.bus.publish)
        with setup_frozen(), SqliteSaver.from_conn_string(str(run.run_dir / "checkpoints.db")) as saver:
            graph = compile_mission(
                run.plan, run.env, checkpointer=saver, reflector=run.model.reflector(), tools=run.registry
            )
            config = {"configurable": {"thread_id": run.run_id}, "recursion_limit": 10_000}
            loop = AgentLoop(
                graph, config, control=run.control, publish=run.bus.publish, pace=run.pace,
                ask=run.settings.approval == "ask", approval_timeout_s=run.settings.approval_timeout_s,
                max_wall_s=run.settings.max_wall_s, after_update=run.save_snapshot,
            )  # fmt: skip
            result = loop.run(None if run.go_on else initial_state(run.plan, run.params))
            final = result.state
        halt = final.get("halt")
        outcome = {"abort": "aborted", "rtl": "returned"}.get(halt or "", "completed")
        if result.stopped is not None:
            carry_out(result.stopped, run.plan.on_abort, run.view(), run.dispatch.call, run.bus.publish)
            signalled = run.control.stopped_by == "signal"
            outcome = "interrupted" if signalled else STOP_OUTCOMES[result.stopped]
        elif result.over_time:
            outcome = "interrupted"
            run.bus.publish("log", level="error", summary=f"over {run.settings.max_wall_s:.0f} s of wall time: RTL")
            carry_out("rtl", run.plan.on_abort, run.view(), run.dispatch.call, run.bus.publish)
    except AgenticUAVError:
        stand_down(run.view(), run.plan.on_abort, run.dispatch.call, run.bus.publish)  # never left hovering
        raise
    except Exception as exc:  # a bug must still leave a report
        run.bus.publish("log", level="error", error=f"{type(exc).__name__}: {exc}", summary=f"failed: {exc}")
        outcome = "failed"
        stand_down(run.view(), run.plan.on_abort, run.dispatch.call, run.bus.publish)
    finally:
        outcome = run.responses.outcome(outcome)  # every critical event answered, or the run says otherwise
        run.faults.close()
        run.failsafes.close()
        run.backend.flush()
        ended = run.where_it_ended()
        outcome = (verdict := check_end(run, outcome)).outcome  # lost, or not home, as its telemetry says
        if run.memory:
            run.memory.finish(run.bus)
        run.bus.publish("run", event="end", outcome=outcome, ended=ended, summary=f"end: {outcome}; {ended}")
        run.close()
    summary = summarise(run, outcome, time.monotonic() - wall0)
    summary.notes += [*run.responses.notes(), f"The aircraft ended {ended}.", *filter(None, [verdict.note])]
    summary.notes += [run.model_note] if run.model_note else []
    track = run.track()
    report = write_report(run.run_dir, summary, run.trace.records, track, run.scene)
    return RunResult(run.run_id, run.run_dir, report, summary, final, track)


__all__ = ["DEFAULT_CEILING_M", "fence_vehicle", "fly", "reach_vehicle"]
