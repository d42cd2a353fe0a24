"""The systems a campaign compares, named on the command line and rebuilt inside each worker.

``--systems`` takes a comma-separated list of ``[NAME=]KIND[:LLM_SPEC]``:

* ``yolo`` — the paper's baseline (detections only), ``rules`` — the deterministic rule reasoner;
* ``llm:PROVIDER:MODEL[@BASE_URL]`` — every assessment by that model (named ``llm:MODEL`` unless given a name);
* ``hybrid`` or ``hybrid:PROVIDER:MODEL[@BASE_URL]`` — rules first, the model on critical events;
* a bare ``llm`` or ``hybrid`` uses ``--llm SPEC`` (or the ``AGENTIC_UAV_LLM`` environment variable).

``NAME=`` sets the label the records and tables use (``gemma=llm:ollama:gemma3:4b``). A :class:`SystemSpec` is
plain data (picklable, written into the manifest): the LLM spec is kept as ``provider:model@base_url`` and never
holds a key, which each worker reads from its environment when it builds the client.

>>> [s.name for s in parse_systems("yolo,rules", environ={})]
['yolo', 'rules']
>>> parse_systems("llm:ollama:gemma3:4b@http://127.0.0.1:11434", environ={})[0]
SystemSpec(name='llm:gemma3:4b', kind='llm', llm='ollama:gemma3:4b@http://127.0.0.1:11434')
>>> parse_systems("rules,fast", environ={})
Traceback (most recent call last):
...
evaluation.campaign.systems.SystemSpecError: --systems: unknown system 'fast'; ...
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import Literal, Protocol

from pydantic import BaseModel, ConfigDict

from agentic_core.contracts.errors import InputError
from agentic_core.reasoning.llm import LLMSpecError, create_client, parse_llm_spec
from agentic_core.reasoning.llm.config import SPEC_ENV
from agentic_core.reasoning.model_reasoners import StructuredChat
from agentic_core.reasoning.reasoners import Reasoner, make_reasoner
from agentic_core.reasoning.rules import RuleSettings

SystemKind = Literal["yolo", "rules", "llm", "hybrid"]


class ClosableChat(StructuredChat, Protocol):
    """A model client a campaign can build a reasoner on and close after the episode."""

    def close(self) -> None: ...


ClientFactory = Callable[["SystemSpec"], ClosableChat]
KINDS: tuple[SystemKind, ...] = ("yolo", "rules", "llm", "hybrid")
NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_.:+@/-]{0,79}$")
USAGE = "[NAME=]KIND[:LLM_SPEC] with KIND one of yolo, rules, hybrid, llm (e.g. yolo,rules,llm:ollama:gemma3:4b)"


class SystemSpecError(InputError):
    """A ``--systems`` entry that cannot be used: unknown kind, bad LLM spec, a missing model, a duplicate name."""


class SystemSpec(BaseModel):
    """One system of a campaign: its label, its kind and (for ``llm``/``hybrid``) the model, without secrets."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    kind: SystemKind
    llm: str | None = None


def parse_systems(
    text: str | Sequence[str], *, llm: str | None = None, environ: Mapping[str, str] | None = None
) -> list[SystemSpec]:
    """The systems of a ``--systems`` value (see the module docs); ``llm`` is the ``--llm`` spec for bare ``llm``
    and ``hybrid``. Raises :class:`SystemSpecError` with a message naming the entry."""
    import os

    env = os.environ if environ is None else environ
    items = [text] if isinstance(text, str) else list(text)
    entries = [part.strip() for item in items for part in item.split(",") if part.strip()]
    if not entries:
        raise SystemSpecError(f"--systems: no system given; expected {USAGE}")
    systems: list[SystemSpec] = []
    for entry in entries:
        systems.append(_parse_entry(entry, llm, env))
    seen: dict[str, str] = {}
    for spec, entry in zip(systems, entries, strict=True):
        if spec.name in seen:
            raise SystemSpecError(
                f"--systems: {seen[spec.name]!r} and {entry!r} are both named {spec.name!r}; "
                "give one a name with NAME=KIND[:LLM_SPEC]"
            )
        seen[spec.name] = entry
    return systems


def _parse_entry(entry: str, default_llm: str | None, env: Mapping[str, str]) -> SystemSpec:
    name: str | None = None
    body = entry
    head, eq, rest = entry.partition("=")
    if eq and ":" not in head:
        name, body = head.strip(), rest.strip()
        if not NAME_PATTERN.match(name):
            raise SystemSpecError(
                f"--systems: {entry!r}: the name {name!r} must start with a letter (letters, digits, _.:+@/-)"
            )
    kind_text, colon, spec_text = body.partition(":")
    kind = kind_text.strip().lower()
    if kind not in KINDS:
        raise SystemSpecError(f"--systems: unknown system {body!r}; expected {USAGE}")
    if kind in ("yolo", "rules"):
        if colon:
            raise SystemSpecError(f"--systems: {entry!r}: {kind} takes no model")
        return SystemSpec(name=name or kind, kind=kind)
    spec = spec_text.strip() if colon else (default_llm or env.get(SPEC_ENV, "").strip())
    if not spec:
        raise SystemSpecError(
            f"--systems: {entry!r} needs a model: write {kind}:PROVIDER:MODEL[@BASE_URL], or pass --llm SPEC "
            f"(or set {SPEC_ENV})"
        )
    try:
        config = parse_llm_spec(spec, environ=env, source=f"--systems {entry!r}" if colon else "--llm")
    except LLMSpecError as exc:
        raise SystemSpecError(str(exc)) from None
    default_name = "hybrid" if kind == "hybrid" else f"llm:{config.model}"
    return SystemSpec(name=name or default_name, kind=kind, llm=config.spec())


def build_reasoner(
    system: SystemSpec, *, rules: RuleSettings, goal: str, clients: ClientFactory | None = None
) -> tuple[Reasoner, Callable[[], None]]:
    """A fresh reasoner for one episode, and what to call when the episode is over (it closes a model client).
    ``clients`` makes the model client of an ``llm`` or ``hybrid`` system (a campaign's cache and limits), else
    :func:`~agentic_core.reasoning.llm.create_client` from its spec.

    Raises whatever building it raises (a spec whose key has gone from the environment): the episode turns that
    into error records.
    """
    if system.kind in ("yolo", "rules"):
        return make_reasoner(system.kind, rules=rules), _nothing
    client: ClosableChat = clients(system) if clients is not None else create_client(system.llm)
    try:
        reasoner = make_reasoner(system.kind, client=client, goal=goal, rules=rules)
    except Exception:
        client.close()
        raise
    return reasoner, client.close


def _nothing() -> None:
    return None


__all__ = ["KINDS", "ClientFactory", "ClosableChat", "SystemSpec", "SystemSpecError", "build_reasoner", "parse_systems"]
