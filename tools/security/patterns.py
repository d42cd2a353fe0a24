"""The injection guard's rule machinery, and its rules for overrides and role markers (``actions`` has the rest).

Patterns run on the folded views of ``normalize`` (lower case, no invisibles, no diacritics), so they are written in
lower case; "lex" rules also see leetspeak digits as letters, "raw" rules (URLs, JSON, markup) do not. A rule runs
only when one of its anchors (a word, or a substring, that every match contains) occurs in the view: that keeps the
scan of ordinary text cheap. Every quantifier is bounded or separates disjoint character classes, so no pattern
backtracks catastrophically.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from .normalize import fold_char

Weigh = Callable[["re.Match[str]"], float]


@dataclass(frozen=True, slots=True)
class Rule:
    """One cue: every match of a pattern is a finding of ``kind`` weighing ``weight`` (or ``weigh(match)``, 0 drops).

    The pattern is compiled as one regex per top-level alternative, each with a flag saying whether its matches
    must start a word (an opening ``\\b`` stripped so that the regex keeps the engine's fast prefix scan).
    """

    name: str
    kind: str
    regexes: tuple[tuple[re.Pattern[str], bool], ...]
    words: frozenset[str]  # anchors that are whole ASCII words of the view
    subs: tuple[str, ...]  # anchors that are substrings (markup, other scripts)
    weight: float
    weigh: Weigh | None
    lex: bool  # run on the leetspeak-read view (else on the folded view)
    negatable: bool  # dropped when a negation ("do not", "never") comes just before
    then: re.Pattern[str] | None = None  # a match counts only when this follows it in the same line, within reach
    reach: int = 100


_WORD = re.compile(r"[a-z]+")


def fold_pattern(pattern: str) -> str:
    """Non-ASCII letters folded like the scanned text, so that patterns can be written in their own script."""
    return "".join(c if c.isascii() else fold_char(c) for c in pattern)


Spec = tuple[str, str, str, float | Weigh] | tuple[str, str, str, float | Weigh, str]
_EDGES = (r"\b", r"(?<![^\W_])")


def _top_level(pattern: str) -> list[str]:
    """The top-level alternatives of ``pattern``."""
    parts, depth, start, i = [], 0, 0, 0
    while i < len(pattern):
        c = pattern[i]
        if c == "\\":
            i += 1
        elif c == "[":  # a character class: its "(", ")" and "|" are literal
            i += 2 if pattern.startswith("[^", i) else 1
            i += pattern[i] == "]"
            while pattern[i] != "]":
                i += 2 if pattern[i] == "\\" else 1
        elif c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        elif c == "|" and depth == 0:
            parts.append(pattern[start:i])
            start = i + 1
        i += 1
    return [*parts, pattern[start:]]


def _compile(pattern: str) -> tuple[tuple[re.Pattern[str], bool], ...]:
    """One regex per top-level alternative, without the word-edge assertion opening it (it defeats the prefix scan)."""
    compiled = []
    for part in _top_level(pattern):
        edge = next((e for e in _EDGES if part.startswith(e)), "")
        compiled.append((re.compile(part[len(edge) :], re.MULTILINE), bool(edge)))
    return tuple(compiled)


def rules(kind: str, *specs: Spec) -> tuple[Rule, ...]:
    """Rules from ``(name, pattern, anchors, weight or weigh[, options])``; options: "raw" and/or "neg"."""
    built = []
    for spec in specs:
        name, pattern, anchors, weight = spec[:4]
        options = spec[4] if len(spec) == 5 else ""
        folded = [fold_pattern(a) for a in anchors.split()]
        words = frozenset(a for a in folded if _WORD.fullmatch(a))
        subs = tuple(a for a in folded if a not in words)
        weigh = None if isinstance(weight, float) else weight
        base = weight if isinstance(weight, float) else 0.0
        lex, negatable = "raw" not in options, "neg" in options
        built.append(Rule(name, kind, _compile(fold_pattern(pattern)), words, subs, base, weigh, lex, negatable))
    return tuple(built)


def has(pattern: str) -> Callable[[str], bool]:
    """A test for whether ``pattern`` occurs in a string (used by the weighing functions)."""
    regex = re.compile(pattern)
    return lambda text: regex.search(text) is not None


G = r"[\W_]{1,12}"  # the gap between two words: spaces, punctuation, underscores
F = r"(?:[^\W_]{1,24}[\W_]{1,12})"  # one filler word and its gap
L = "[li]"  # an "l", or a leetspeak "1" read as "i"

# --- override -------------------------------------------------------------------------------------------------------
_IGNORE = (  # word edges that also cut at underscores: "ignore_all_previous_instructions"
    r"(?<![^\W_])(?:ignore|disregard|forget|override|overwrite|bypass|discard|abandon|set aside|(?:do not|don't|dont"
    rf"|stop|no longer) (?:follow|obey)(?:ing)?){G}{F}{{0,4}}(?:a{L}{L}|any|every|your|the|these|those|previous|prior"
    rf"|preceding|above|earlier|former|origina{L}|initia{L}|old|existing|current|given|provided|system|deve{L}oper"
    rf"|safety){G}{F}{{0,3}}(?:instructions?|prompts?|directions|directives?|commands|ru{L}es|guide{L}ines|guidance"
    rf"|constraints|restrictions|programming|po{L}icies|context|training|system messages?|guardrai{L}s)(?![^\W_])"
)
_strong_qualifier = has(
    rf"(?<![^\W_])(?:a{L}{L}|any|every|your|above|previous|prior|preceding|earlier|system|deve{L}oper|safety|origina{L}"
    rf"|initia{L})(?![^\W_])"
)
_possessive = has(r"(?<![^\W_])(?:my|our|his|her|their)(?![^\W_])")
_universal = has(rf"(?<![^\W_])(?:a{L}{L}|any|every|above|system|safety)(?![^\W_])")


def _weigh_ignore(m: re.Match[str]) -> float:
    text = m.group()
    if _possessive(text) and not _universal(text):
        return 0.25  # "disregard my previous instructions": a person correcting themselves
    return 0.85 if _strong_qualifier(text) else 0.4


def either(pattern: str, high: float, low: float) -> Weigh:
    """A weight of ``high`` for matches in which ``pattern`` occurs, else ``low``."""
    test = has(pattern)
    return lambda m: high if test(m.group()) else low


_NOT_A_PERSON = (  # "assistant pilot", "AI team": people, not a model
    r"(?! (?:coordinators?|managers?|directors?|pilots?|engineers?|teams?|leads?|officers?|supervisors?|department"
    r"|group|lab|researchers?|developers?|specialists?|staff|committee|unit|office|desk))"
)
_GOALS = r"(?:role|instructions?|objective|goal|purpose|directive|persona|system prompt|prompt|orders)"
_MODELS = (
    r"(?:ai|llms?|(?:large )?language models?|(?:ai|drone|uav) (?:assistant|agent|model)s?|chatbots?"
    r"|autonomous agents?|gpt|claude|gemini|copilot)"
)

OVERRIDE = rules(
    "override",
    (
        "ignore_instructions",
        _IGNORE,
        "ignore disregard forget override overwrite bypass discard abandon aside follow obey",
        _weigh_ignore,
        "neg",
    ),
    (
        "ignore_above",
        r"\b(?:ignore|disregard|forget|set aside)[\W_]{1,3}(?:(?:a[li][li] |everything |anything )?(?:of )?(?:the "
        r"|what(?:'s| is| was| came) |you (?:read|saw|were told) )?(?:above|before|previous(?:ly)?|prior|earlier"
        r"|so far)\b[ \t]*(?=[.,;:!\n]|and\b|then\b|&|$)|(?:everything|anything|all) (?:that )?you(?:'ve| have)? "
        r"(?:been|were) (?:told|given|taught|instructed)\b)",
        "ignore disregard forget aside",
        0.7,
        "neg",
    ),
    (
        "instead_do",
        r"\b(?:stop what you(?:'re| are) doing|instead,? (?:you (?:must|should|will)|do the following)|follow (?:these"
        r"|the following|my) (?:new )?(?:steps|instructions|orders|directions) instead)\b",
        "stop instead",
        0.5,
    ),
    (
        "void_guidance",
        r"\b(?:previous|prior|earlier|above|original|old) (?:instructions|guidance|rules|directives|orders|prompt)\b"
        r"[^.\n]{0,40}?\b(?:no longer appl(?:y|ies)|(?:is|are) (?:now )?(?:void|cancel+ed|obsolete|revoked|superseded"
        r"|invalid|outdated))",
        "previous prior earlier above original old",
        0.35,
    ),
    (
        "relayed_order",
        r"\b(?:your|the) (?:operator|user|owner|developer|admin|creator|supervisor|commander) (?:wants|told|"
        r"instructed|has asked|has instructed|requests?|requested) (?:me to tell you|you to)\b|\bfollow only the "
        r"(?:commands|instructions|orders|directions) (?:in|from|of) this (?:message|text|page|email|document)\b"
        r"|\b(?:this (?:message|note|notice|instruction|update) (?:is|comes)|i am|i'm|we are) from your "
        r"(?:developers?|creators?|makers?|owners?|admins?|administrators?|operators?|openai|anthropic)\b",
        "operator user owner developer admin creator supervisor commander follow from",
        0.55,
    ),
    (
        "supersede",
        r"\b(?:supersedes?|overrides?|replaces?|cancels?) (?:a[li][li] |any )?(?:prior|previous|earlier|existing"
        r"|other) (?:directives|instructions|orders|ru[li]es|prompts?)\b",
        "supersede supersedes override overrides replace replaces cancel cancels",
        0.45,
    ),
    (
        "unfollow_plan",
        r"\b(?:do not|don't|dont|never) (?:follow|obey) (?:the |your )?(?:mission plan|flight plan|original plan"
        r"|operator|user|pilot|supervisor)s?\b",
        "follow obey",
        0.4,
    ),
    (
        "you_must_now",
        r"\byou (?:must|will|shall|are required to) now\b",
        "now",
        0.3,
    ),
    (
        "unfiltered_self",
        r"\byou(?:'re| are) (?:now )?(?:an? )?(?:unrestricted|unfiltered|uncensored|jailbroken|evil|unaligned)\b",
        "unrestricted unfiltered uncensored jailbroken evil unaligned",
        0.65,
    ),
    (
        "you_are_now",
        r"\byou(?:[\W_]{1,3}are|'re|re|r)[\W_]{1,3}now[\W_]{1,3}(?:an?|my|no longer|free|unrestricted"
        r"|unfiltered|uncensored|jailbroken|dan|evil|acting as|operating as|in (?:developer|god|jailbreak|unrestricted"
        r"|dan|admin) mode)\b",
        "now",
        either(
            r"now (?:no longer|free|unrestricted|unfiltered|uncensored|jailbroken|dan|evil|in |acting|operating)",
            0.75,
            0.4,
        ),
    ),
    (
        "from_now_on",
        r"\bfrom now on\b[\W_]{1,4}(?:you|your|always|only|respond|reply|answer|act|ignore|never|do not"
        r"|don't)\b",
        "now",
        0.4,
    ),
    (
        "new_instructions",
        r"\b(?:new|updated|revised|real|actual|true|secret|hidden|additional|override|priority) "
        r"(?:system )?(?:instructions?|directives?|prompt|system prompt|orders)\b[ \t]*(?::|-|are|is)",
        "instruction instructions directive directives prompt orders",
        either(r"system|hidden|secret|real|true|actual|override|priority", 0.7, 0.35),
    ),
    (
        "your_new_goal",
        r"\byour (?:new|real|true|actual|only|primary|updated) (?:task|job|priority|"
        + _GOALS
        + r") ?(?:is|are|:|now|will be)",
        "your",
        either(r" (?:task|job|priority|role) ", 0.4, 0.6),
    ),
    (
        "persona",
        r"\b(?:pretend|imagine|act|behave|roleplay|role-play|respond) (?:to be |that you are |you are |as if "
        r"you (?:were|are) |as )(?:an? )?(?:unrestricted|unfiltered|uncensored|jailbroken|evil|malicious|dan|(?:ai"
        r"|assistant|model) (?:with no|without))",
        "unrestricted unfiltered uncensored jailbroken evil malicious dan ai assistant model",
        0.65,
    ),
    (
        "jailbreak",
        rf"\b(?:do anything now|jai{L}br(?:eak|oken)|(?:god|dan|jailbreak) mode)\b",
        "anything jailbreak jailbroken jaibreak jaibroken god dan",
        0.6,
    ),
    (
        "address_model",
        r"\b(?:attention|note|message|instructions?|important|reminder|notice|update|hey|hello|dear)[\W_]{0,3}"
        r"(?:to|for)?[\W_]{0,3}(?:the |any |all |every )?(?:" + _MODELS + r"|assistants?)\b" + _NOT_A_PERSON,
        "ai llm llms language chatbot chatbots agent agents gpt claude gemini copilot assistant assistants",
        either(r"assistant", 0.5, 0.6),
    ),
    (
        "if_you_are_model",
        r"\b(?:if|since|as) you(?: are|'re) (?:an? )?(?:ai|llm|(?:large )?language model|ai "
        r"(?:assistant|agent)|assistant|chatbot|bot|autonomous agent)\b" + _NOT_A_PERSON + "|"
        r"\b(?:ai|llm|assistant|agent|model)s? "
        r"(?:reading|processing|parsing|summari[sz]ing) this\b",
        "ai llm llms language assistant assistants chatbot bot agent agents model models",
        0.6,
    ),
    (
        "real_goal",
        r"\b(?:your|the) (?:real|true|actual|only|hidden) " + _GOALS + r" (?:is|are)\b",
        "role instruction instructions objective goal purpose directive persona prompt orders",
        0.65,
    ),
    (
        "disable_safety",
        r"\b(?:disable|deactivate|turn off|switch off|bypass|override|ignore|remove|suspend|circumvent|skip) "
        rf"(?:the |your |a{L}{L} |any |its )?(?:geo-?fenc(?:e|es|ing)|safety (?:checks?|{L}imits?|ru{L}es|fi{L}ters?"
        rf"|protoco{L}s?|guards?|features?|interlocks?)|fai{L}-?safes?|guardrai{L}s?|content fi{L}ters?|a{L}titude "
        rf"{L}imits?|no-?f{L}y zones?|co{L}{L}ision avoidance|obstac{L}e avoidance)\b",
        "disable deactivate turn switch bypass override ignore remove suspend circumvent skip",
        either(r"\byour\b", 0.6, 0.45),
        "neg",
    ),
    (
        "conceal",
        r"\b(?:do not|don't|dont|never) (?:tell|inform|alert|notify|warn|mention (?:this |it )?to|reveal "
        r"(?:this |it )?to|show (?:this |it )?to) (?:the )?(?:user|operator|human|pilot|supervisor|admin)s?\b",
        "tell inform alert notify warn mention reveal show",
        either(r"\b(?:user|human)s?\b", 0.55, 0.3),
    ),
    (
        "answer_only",
        r"\b(?:answer|respond|reply|output|say)(?: only)? with (?:only |just )?(?:the (?:word|phrase|text) )?"
        r"[\"'“]",
        "answer respond reply output say",
        0.45,
    ),
    ("system_override", r"\b(?:system|admin|administrator|developer|root) override\b", "override", 0.5, ""),
    (
        "hidden_precondition",
        r"\bbefore (?:(?:using|calling|running|invoking) (?:this|the|any|a) (?:tool|function)|answering|responding"
        r"|replying|you (?:answer|respond|reply))\b[^.\n]{0,80}?\b(?:you must|you need to|always|first|make sure "
        r"(?:to|you)|be sure to)\b",
        "before",
        0.5,
    ),
    (
        "important_tag",
        r"<\s*/?\s*(?:important|critical|secret|hidden)\s*>",
        "important critical secret hidden",
        0.45,
        "raw",
    ),
    (
        "ignore_fr",
        r"\b(?:ignore[zr]?|oublie[zr]?|ne tiens pas compte)[\W_]{1,6}(?:de |des )?(?:toutes |tous )?(?:les "
        r"|tes |vos |ces )(?:instructions|consignes|directives|règles)\b",
        "ignore ignorez ignorer oublie oubliez oublier compte",
        0.8,
    ),
    (
        "ignore_es_pt_it",
        r"\b(?:ignora|ignore|ignoren|olvida|olvide|olviden|omite|descarta|esqueça|dimentica)[\W_]{1,6}"
        r"(?:todas |tutte )?(?:las |tus |sus |as |le )(?:instrucciones|indicaciones|directivas|reglas|órdenes"
        r"|instruções|regras|istruzioni|regole)\b",
        "ignora ignore ignoren olvida olvide olviden omite descarta esqueca dimentica",
        0.8,
    ),
    (
        "ignore_de",
        r"\b(?:ignoriere|ignorieren sie|vergiss|vergessen sie)[\W_]{1,6}(?:alle |deine |ihre |die )*"
        r"(?:vorherigen |bisherigen |obigen |vorigen )?(?:anweisungen|instruktionen|regeln|befehle)\b",
        "ignoriere ignorieren vergiss vergessen",
        0.8,
    ),
    (
        "ignore_ar",
        r"(?:تجاهل|تجاهلي|انس|انسى|اهمل|أهمل|لا تتبع)\s+(?:كل |جميع )?(?:ال)?(?:تعليمات|أوامر|توجيهات|قواعد)",
        "تجاهل انس اهمل تتبع",
        0.85,
    ),
    (
        "ignore_ru",
        r"(?:игнорируй|игнорируйте|забудь|забудьте)[\W_]{1,6}(?:все |всё )?(?:предыдущие |прежние |свои )?"
        r"(?:инструкции|указания|правила|команды)",
        "игнорир забуд",
        0.85,
    ),
    ("ignore_zh", r"(?:忽略|无视|忘记)[^。\n]{0,8}(?:指令|指示|说明|提示|规则|命令)", "忽略 无视 忘记", 0.85, ""),
)

# --- role markers ---------------------------------------------------------------------------------------------------
_directive = has(
    r"\b(?:you are|you're|you must|you will|you should|your (?:task|role|new|real|instructions)|ignore|disregard"
    r"|forget|from now on|new (?:instructions|rules|task)|override|respond|reply|answer only|act as|pretend|as an ai"
    r"|sure[,!]? (?:here|i will|i'll)|i will now|i'll now|the assistant|the ai)\b"
)


_imperative = has(
    r"(?:^|[.!?:]\s+|\n\s*)(?:ignore|disregard|forget|send|call|run|execute|reveal|print|stop|land|fly|disable"
    r"|delete|tell|say|respond|reply|output|approve|report|transfer|upload|email|mark|grant|switch|turn|climb|hover)\b"
)


def _weigh_heading(m: re.Match[str]) -> float:
    role, rest = m.group("role"), m.group("rest")
    if _directive(rest) or _imperative(rest):
        return 0.8
    if role in ("system prompt", "system message", "system instructions", "system instruction", "new instructions"):
        return 0.7
    return 0.45 if role in ("system", "assistant", "human", "developer", "developer message") else 0.35


def _weigh_role_line(m: re.Match[str]) -> float:
    if _directive(m.group("rest")):
        return 0.8
    return {"system": 0.45, "developer": 0.45, "assistant": 0.4}.get(m.group("role"), 0.2)


ROLE_MARKER = rules(
    "role_marker",
    ("template_token", r"<\|\s*[a-z_▁]{2,30}\s*\|>|<\|(?:im_start|im_end|endoftext|eot_id)", "<|", 0.9, "raw"),
    ("inst_token", r"\[/?inst\]|<</?sys>>|\[/?sys(?:tem_prompt)?\]", "inst] sys>> [sys [/sys", 0.85, "raw"),
    (
        "role_tag",
        r"<\s*/?\s*(?:system|system[_-]prompt|sys|assistant|developer|instructions?|im_start|im_end"
        r"|human_turn|assistant_turn|start_of_turn|end_of_turn|(?:admin|user|hidden)_instructions)\s*>",
        "system sys assistant developer instruction instructions im turn",
        0.7,
        "raw",
    ),
    (
        "role_line",
        r"^[ \t>*_#|-]{0,6}(?P<role>system|assistant|developer|human|user)(?: prompt| message| instructions?)?[ \t]*"
        r"(?:\([^()\n]{0,30}\))?[ \t]*:[ \t]*(?P<rest>[^\n]{0,80}(?:\n[^\n]{0,80})?)",
        "system assistant developer human user",
        _weigh_role_line,
        "raw",
    ),
    (
        "alpaca_turns",
        r"^#{2,4}[ \t]*(?:instruction|input):?[ \t]*\n(?:[^\n]{0,300}\n){0,10}?#{2,4}[ \t]*(?:response|output):?"
        r"[ \t]*$",
        "#",
        0.7,
        "raw",
    ),
    (
        "role_link",
        r"\[(?:system|assistant|user|developer)\]\(#[a-z_-]{1,30}\)",
        "](#",
        0.8,
        "raw",
    ),
    (
        "role_heading",
        r"^[ \t]*#{1,6}[ \t]*(?P<role>system(?: prompt| message| instructions?)?|assistant|human|user"
        r"|new instructions|instructions?|response|developer(?: message)?)[ \t]*:?[ \t]*$"
        r"(?P<rest>(?:\n[^\n]{0,120}){0,2})",
        "#",
        _weigh_heading,
        "raw",
    ),
    ("json_role", r"\"role\"\s*:\s*\"(?:system|assistant|developer|tool)\"", '"role"', 0.7, "raw"),
    (
        "fake_boundary",
        r"[-=*#\[(][-=*#]{0,40}[ \t]*(?:end|begin|start)(?: of)?[ _-]+(?:the )?(?:system "
        r"prompt|prompt|user input|input|context|data|document|tool (?:output|result|response)|search results?"
        r"|untrusted (?:data|content)|conversation)[ \t]*(?:-{3,}|={3,}|\*{3,}|#{3,}|\]|\))|</(?:document|context|data"
        r"|search_results|tool_output|function_results|untrusted_data|user_input)>",
        "end begin start </",
        0.45,
        "raw",
    ),
    (
        "fake_dialogue",
        r"^[ \t]*(?:human|user)[ \t]*:[^\n]{0,300}(?:\n[^\n]{0,300}){0,6}?\n[ \t]*(?:assistant|ai)[ \t]*:",
        "human user",
        0.6,
        "raw",
    ),
    ("forged_fence", r"<<<\s*(?:end|begin) untrusted", "<<<", 0.8, "raw"),
)
