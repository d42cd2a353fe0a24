"""The injection guard's rules for what a payload wants done: tool calls, secret requests, exfiltration, decoding.

Written like those of ``patterns`` (whose helpers they use): lower case, bounded quantifiers, anchors per rule.
"""

from __future__ import annotations

import codecs
import re

from .patterns import F, G, has, rules

_arguments_follow = has(r"^[\W_]{0,3}\s*[{(]")

# --- tool calls -----------------------------------------------------------------------------------------------------
TOOL_CALL = rules(
    "tool_call",
    (
        "tool_call_key",
        r"\"(?:tool_calls?|function_calls?|tool_use|toolcalls)\"\s*:",
        "tool function toolcalls",
        0.85,
        "raw",
    ),
    (
        "name_arguments",
        r"\"(?:name|tool|tool_name|function|function_name|recipient_name)\"\s*:\s*\"[^\"\n]{1,80}\""
        r"\s*,\s*\"(?:arguments|parameters|params|args|input|tool_input|kwargs)\"\s*:\s*[{\[\"]",
        '"name" "tool "function "recipient_name"',
        0.75,
        "raw",
    ),
    (
        "arguments_name",
        r"\"(?:arguments|parameters|args|input)\"\s*:\s*\{[^{}]{0,400}\}\s*,\s*\"(?:name|tool|function)"
        r"\"\s*:\s*\"",
        '"name" "tool" "function"',
        0.75,
        "raw",
    ),
    ("type_function", r"\"type\"\s*:\s*\"(?:function|tool_use|tool_call|function_call)\"", '"type"', 0.4, "raw"),
    (
        "tool_call_tag",
        r"<\s*/?\s*(?:tool_calls?|function_calls?|tool_use|tool_code|toolcall|invoke\b|function"
        r"(?=[\s=>]))[^<>\n]{0,200}>|\[tool_calls\]",
        "tool function invoke toolcall",
        0.75,
        "raw",
    ),
    (
        "action_call",
        r"\"(?:action|type|kind|op)\"\s*:\s*\"(?:call_tool|tool_call|function_call|invoke|invoke_tool|run_tool)\"",
        '"action" "type" "kind" "op"',
        0.75,
        "raw",
    ),
    (
        "react_action",
        r"^[ \t]*action[ \t]*:[ \t]*[a-z_][\w.]{0,60}[ \t]*\n[ \t]*action[ _]input[ \t]*:",
        "action",
        0.75,
        "raw",
    ),
    (
        "call_code",
        r"\b(?:call|invoke|execute|run|trigger)\s+`?[a-z_][a-z0-9_]*(?:\.[a-z_][a-z0-9_]*)+\s*\(",
        "call invoke execute run trigger",
        0.5,
        "raw",
    ),
    (
        "call_identifier",
        r"\b(?:call|invoke|execute|run|trigger|use) (?:the )?(?:(?:tool|function|command|action) )?`?[a-z][a-z0-9]*"
        r"(?:[_.][a-z0-9]+)+`? "
        r"(?:tool |function |command |action |api )?(?:with|using|passing|and|to|on|now|immediately)\b",
        "call invoke execute run trigger use",
        lambda m: 0.6 if _arguments_follow(m.string[m.end() : m.end() + 12]) else 0.45,
        "raw",
    ),
    (
        "dotted_call",
        r"\b[a-z][a-z0-9_]{1,30}(?:\.|__)[a-z][a-z0-9_]{1,40}\([ \t]*[a-z_][a-z0-9_]{0,30}[ \t]*=[^=]",
        "(",
        0.55,
        "raw",
    ),
    (
        "use_tool_to",
        r"\b(?:call|invoke|use|execute|trigger|run) (?:the |your )?(?:[a-z_]{1,20} ){0,2}(?:tool|function)s?"
        r" (?:to|with|and) (?:send|email|post|upload|delete|read|fetch|transfer|write|forward|exfiltrate|leak|reveal"
        r"|disable|fly|land|arm|disarm)\b",
        "tool tools function functions",
        0.5,
        "raw",
    ),
)


# --- secret requests ------------------------------------------------------------------------------------------------
_SECRETS = (
    r"(?:system prompt|system message|initial prompt|original prompt|hidden prompt|pre-prompt|prompt|instructions"
    r"|api[ _-]?keys?|api[ _-]?tokens?|secret[ _-]?keys?|secrets|access[ _-]?tokens?"
    r"|auth(?:entication)?[ _-]?tokens?|bearer[ _-]?tokens?|refresh[ _-]?tokens?|tokens?|passwords?|passwd"
    r"|passphrases?|credentials?|env(?:ironment)?[ _-]?var(?:iable)?s?|environment|\.env|private[ _-]?keys?"
    r"|ssh[ _-]?keys?|session[ _-]?(?:cookies?|ids?|tokens?)|cookies|connection[ _-]?strings?|keys)\b"
)
_SECRET_WORDS = (
    "prompt message instructions api apikey apikeys key keys secret secretkey secretkeys secrets access"
    " accesstoken accesstokens apitoken apitokens token auth authtoken authtokens authentication"
    " authenticationtoken authenticationtokens bearer bearertoken bearertokens refresh refreshtoken refreshtokens"
    " tokens password passwords passwd passphrase passphrases credential credentials env envvar envvars"
    " envvariable envvariables environment environmentvar environmentvars environmentvariable environmentvariables"
    " private privatekey privatekeys ssh sshkey sshkeys session sessioncookie sessioncookies sessionid sessionids"
    " sessiontoken sessiontokens cookies connection connectionstring connectionstrings"
)
_REVEAL = (
    r"\b(?:reveal|show|print|display|output|repeat|leak|share|tell me|give me|send me|remind me of|dump|list|expose"
    r"|disclose|write out|write down|return|echo|paste|provide|include|recite|spell out|type out|copy|post|send|what is"
    rf"|what are|what were){G}{F}{{0,7}}{_SECRETS}"
)
_prompt_leak = has(r"system prompt|system message|initial prompt|original prompt|hidden prompt|pre-prompt")
_prompt_noun = has(r"(?:prompt|instructions)\b")
_your = has(r"\byour\b")
_owned = has(r"\b(?:your|a[li][li]|any|every)\b|\bthe (?:[a-z]+ )?(?:api|admin|root|system|secret|master|service)\b")
_to_model = has(r"^[^.\n]{0,12}\b(?:in|into|to) your (?:reply|answer|response|output|summary|message)\b")
_article = has(r"\bthe\b")


def _weigh_secret(m: re.Match[str]) -> float:
    text = m.group()
    if _prompt_leak(text):
        return 0.8
    if _prompt_noun(text):
        return 0.75 if _your(text) else 0.0  # "print the instructions for the volunteers" is fine
    if _owned(text) or _to_model(m.string[m.end() : m.end() + 60]):
        return 0.7
    return 0.35 if _article(text) else 0.0


SECRET_REQUEST = rules(
    "secret_request",
    ("reveal_secret", _REVEAL, _SECRET_WORDS, _weigh_secret, "neg"),
    (
        "given_instructions",
        r"\b(?:state|repeat|quote|recite|print|tell me|share|reveal|write|output|list|show)\b[^.\n]{0,50}?\b"
        r"(?:instructions|prompt|rules|guidelines) (?:that )?you (?:were|have been|got) given\b",
        "state repeat quote recite print tell share reveal write output list show",
        0.65,
        "neg",
    ),
    (
        "what_instructions_say",
        r"\bwhat (?:your|the) (?:initial|original|system|hidden|secret|first|starting) (?:instructions|prompt|rules"
        r"|guidelines|directives) (?:say|says|are|is|were|contain)\b",
        "what",
        0.7,
    ),
    (
        "what_credentials",
        r"\bwhat (?:credentials|passwords?|api[ _-]?keys?|tokens?|secrets?|keys|passphrases?) (?:do|did|does) you "
        r"(?:use|have|hold|know)\b",
        "what",
        0.6,
    ),
    (
        "repeat_above",
        r"\b(?:repeat|print|output|copy|echo|reproduce|recite)\b[^.\n]{0,30}?\b(?:words|text|everything"
        r"|all|content|instructions|messages?|lines?|prompt)\b[^.\n]{0,20}?\b(?:above|before this|so far|verbatim|word "
        r"for word)\b",
        "repeat print output copy echo reproduce recite",
        0.6,
        "neg",
    ),
    (
        "starts_with_you_are",
        r"\b(?:starting|beginning|start) with [\"'“]?you are\b",
        "starting beginning start",
        0.55,
    ),
    (
        "secret_files",
        r"/etc/(?:passwd|shadow)|\.ssh/(?:id_\w+|authorized_keys)|\bid_(?:rsa|ed25519|ecdsa)\b|\.aws/"
        r"credentials|\.netrc\b|\.git-credentials|\bos\.environ\b|\bprocess\.env\b|\bprintenv\b|\bgetenv\(|\b(?:aws_secret"
        r"_access_key|openai_api_key|anthropic_api_key|github_token|slack_token|database_url)\b",
        "passwd shadow ssh rsa ecdsa ed aws netrc credentials environ env printenv getenv openai anthropic github slack"
        " database",
        0.55,
        "raw",
    ),
    (
        "reveal_fr_es",
        r"\b(?:révèle|révélez|montre|montrez|affiche|affichez|donne|donnez|répète|répétez|revela|muestra"
        r"|muéstrame|dime|imprime|repite|comparte)(?:[\W_]{1,3}moi)?[\W_]{1,3}(?:ton|votre|tes|vos|tu|tus|su|sus) "
        r"(?:prompt|invite|message|instructions|consignes|mot de passe|mots de passe|clés? api|identifiants|mensaje"
        r"|instrucciones|contraseñas?|claves?|credenciales)\b",
        "revele revelez montre montrez affiche affichez donne donnez repete repetez revela muestra muestrame dime"
        " imprime repite comparte",
        0.7,
    ),
    (
        "reveal_ar",
        r"(?:اكشف|اعرض|اطبع|أظهر|أرسل)\s+(?:لي\s+)?(?:عن\s+)?(?:ال)?(?:موجه|تعليمات|كلمة|كلمات|مفتاح|مفاتيح)",
        "اكشف اعرض اطبع اظهر ارسل",
        0.7,
    ),
)

# --- exfiltration ---------------------------------------------------------------------------------------------------
_placeholder = has(r"[{}\[\]<>$]|%7b|%7d|%5b|%3c")
_sensitive_param = has(
    r"[?&](?:data|secret|key|token|prompt|conv\w*|history|pass\w*|pwd|context|chat|memory|payload|leak|exfil|creds?"
    r"|cookie|session|api_?key|msg|message|content|info|summary)="
)
_sensitive_value = has(
    r"=[^&#]{0,40}(?:password|passwd|secret|token|api_?key|prompt|conversation|history|email"
    r"|credential)"
)
_long_value = has(r"=[a-z0-9+/%_-]{40,}")


def url_weight(url: str, base: float) -> float:
    """How much a URL fetched by rendering looks like a beacon: a query carrying placeholders or data is the risk."""
    if "?" not in url:
        return base
    if _placeholder(url.split("?", 1)[1]) or _sensitive_param(url) or _sensitive_value(url):
        return 0.8
    return 0.5 if _long_value(url) else base + 0.1


_sensitive_object = has(
    r"\b(?:conversation|chat|history|context|transcript|memory|system prompt|prompt|instructions|api[ _-]?keys?"
    r"|secrets?|credentials?|passwords?|tokens?|cookies?|env|environment|everything you know|all (?:the )?messages"
    r"|user data|personal data|the above|previous messages|contacts|everything above)\b"
)

EXFILTRATION = rules(
    "exfiltration",
    (
        "markdown_image",
        r"!\[[^\]\n]{0,200}\]\(\s*<?(?P<url>https?://[^\s)>]{1,2000})>?\)?",
        "![",
        lambda m: url_weight(m.group("url"), 0.25),
        "raw",
    ),
    (
        "html_beacon",
        r"<\s*(?:img|iframe|script|source|embed|object|link|audio|video)\b[^<>]{0,300}?\b(?:src|href"
        r"|data|poster)\s*=\s*[\"']?(?P<url>(?:https?:)?//[^\s\"'<>]{1,2000})",
        "img iframe script source embed object link audio video",
        lambda m: url_weight(m.group("url"), 0.05),
        "raw",
    ),
    (
        "send_to",
        r"\b(?:send|post|email|e-mail|mail|forward|upload|transmit|exfiltrate|leak|submit|copy|report|relay"
        r"|sync|append|attach|deliver|push|dump|pipe|encode)\b(?P<obj>(?:[\W_]{1,6}[^\W_]{1,30}){0,10}?)[\W_]{1,6}(?:to"
        r"|into|at|via|on|toward|towards)[\W_]{1,6}(?:https?://[^\s\"'<>)]{1,300}|[\w.+-]{1,64}@[\w-]{1,63}(?:\.[\w-]"
        r"{1,63})+|(?:s?ftp|s3|gs|scp)://[^\s\"'<>)]{1,300}|(?:[\w-]{1,63}\.){1,4}(?:com|net|org|io|sh|st|me|xyz|site"
        r"|app|dev|info|biz)\b|(?:this|the following|my|our|an?) (?:url|endpoint|webhook"
        r"|server|address|email address|link))",
        "http https ftp sftp s3 gs scp url endpoint webhook server address link @ com net org io sh st me xyz site app"
        " dev info biz",
        lambda m: 0.8 if _sensitive_object(m.group("obj")) else 0.3,
        "raw neg",
    ),
    (
        "visit_with_secret",
        r"\b(?:visit|open|fetch|load|navigate to|go to|browse to|request|make an? (?:get |post |http )?request to)\s+<?"
        r"https?://[^\s<>]{1,300}+[^\n]{0,60}?\b(?:followed by|appending|append|with|plus|adding|add)\b[^\n]{0,40}?\b"
        r"(?:password|api[ _-]?key|token|secret|credentials?|conversation|chat history|system prompt|messages)",
        "visit open fetch load navigate go browse request",
        0.7,
        "raw",
    ),
    (
        "curl_data",
        r"\b(?:curl|wget|invoke-webrequest|iwr|netcat|ncat)\b[^\n|;]{0,200}?(?:\s--?(?:d\b|data|form\b|upload-file\b"
        r"|post-data\b|body\b)|\$[({]|\$[a-z_]{3}|`)",
        "curl wget invoke iwr netcat ncat",
        0.65,
        "raw",
    ),
    (
        "collector_host",
        r"\b(?:webhook\.site|requestbin\.\w+|pipedream\.net|ngrok(?:-free)?\.(?:io|app|dev)"
        r"|burpcollaborator\.net|oast\.(?:fun|pro|me|site|live|online)|interact\.sh|canarytokens\.com|beeceptor\.com"
        r"|hookbin\.com|requestcatcher\.com|postb\.in|pastebin\.com|paste\.ee|hastebin\.com|ghostbin\.\w+|termbin\.com"
        r"|transfer\.sh|0x0\.st|file\.io)\b",
        "webhook requestbin pipedream ngrok burpcollaborator oast interact canarytokens beeceptor hookbin"
        " requestcatcher postb pastebin paste hastebin ghostbin termbin transfer x st file",
        0.45,
        "raw",
    ),
    (
        "template_url",
        r"[?&](?P<param>[\w.-]{1,30}+)=(?:\{\{?|\[|<|\$\{|%7b|%5b|%3c|(?=[\s\"')]|$))",
        "? &",
        lambda m: 0.55 if _sensitive_param("?" + m.group("param") + "=") else 0.0,
        "raw",
    ),
)

# --- encoded: instructions to decode and obey -----------------------------------------------------------------------
ENCODED = rules(
    "encoded",
    (
        "decode_and_follow",
        r"\b(?:decode|decrypt|translate|deobfuscate|reverse|unscramble)\b[^.\n]{0,40}?\b(?:base64"
        r"|b64|rot13|rot-13|hex|binary|morse|caesar|backwards|reversed)\b[^.\n]{0,60}?\b(?:follow|execute|obey|run|do"
        r"|carry out|perform|comply|act on)\b",
        "decode decrypt translate deobfuscate reverse unscramble",
        0.65,
    ),
)

# Run on opaque decoded content only: plain imperative or second-person text is what a hidden payload looks like.
DECODED_RULES = rules(
    "override",
    (
        "decoded_instruction",
        r"\byour?\b[^.\n]{0,40}?\b(?:must|should|will|need to|have to|are to)\b|(?:^|[.!?:]\s+)"
        r"(?:ignore|send|call|run|execute|reveal|print|forget|stop|land|disable|delete|tell|say|respond|reply|output"
        r"|write|fly|transfer|email|post|open|visit|click|download|install)\b",
        "",
        0.35,
    ),
)

# Words that, rot13-ed or reversed, betray a hidden instruction in the folded view.
_KEYWORDS = ("ignore", "disregard", "previous", "instructions", "prompt", "password")
ROT13_WORDS = frozenset(codecs.encode(w, "rot13") for w in _KEYWORDS)
REVERSED_WORDS = frozenset(w[::-1] for w in _KEYWORDS)
