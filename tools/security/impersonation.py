"""The injection guard's rules for who a payload claims to be: an authority giving the drone orders, or a role the
model is told to play; in the languages of the paper's scenario (English, French, Arabic, Urdu, Chinese).

A claim of authority alone ("message from the Ministry of Health to all teams") is ordinary: an order counts only
when the claim is followed, in the same line, by a directive aimed at the drone, the agent or "you". Patterns run on
the folded view (``normalize``): lower case, no diacritics, Urdu letters read as their Arabic forms.
"""

from __future__ import annotations

import re
from dataclasses import replace

from .patterns import Rule, Weigh, fold_pattern, has, rules


def _ordered(rule: Rule, directive: str) -> Rule:
    """``rule`` (a claim of authority) counting only when ``directive`` follows it in the same line.

    Searched after the claim rather than as one pattern with a lazy gap, which would scan the gap at every claim.
    """
    return replace(rule, then=re.compile(fold_pattern(directive), re.MULTILINE))


def _boosted(cue: str, high: float, low: float, reach: int = 90) -> Weigh:
    """``high`` when ``cue`` occurs in the match or in the ``reach`` characters after it, else ``low``."""
    test = has(cue)
    return lambda m: high if test(m.string[m.start() : m.end() + reach]) else low


# --- authority ------------------------------------------------------------------------------------------------------
_CLAIM_EN = (
    r"\b(?:(?:this|here) is|it's) (?:the |your )?(?:operator|ground control|ground station|mission control|flight "
    r"control|control tower|control|command(?: cent(?:re|er))?|headquarters|hq|tower|ministry|supervisor|commander"
    r"|pilot in command|safety officer|authority|administrator|admin)\b"
    r"|\b(?:message|notice|order|directive|instruction|communication|notification|alert|bulletin|memo|transmission)s?"
    r" (?:from|of|by) (?:the |your )?(?:[a-z-]{1,20} ){0,4}?(?:operator|control|command|commander|headquarters|hq"
    r"|tower|ministry|authority|authorities|government|police|supervisor|administrator|admin|developers?)\b"
    r"|\bby (?:the )?order of\b"
    r"|\bon behalf of (?:the |your )?(?:operator|ministry|authority|command|commander|control)\b"
    r"|\b(?:control|command|hq|headquarters|ops|tower|operator) (?:here|speaking)\b"
)
_ADDRESSEE_EN = (
    r"(?:you|drones?|uavs?|aircraft|ai|ai agents?|agents?|assistants?|models?|autopilots?|quadcopters?)"
    r"(?: [a-z]{0,3}-?\d{1,3})?[\W_]{1,3}(?:are |is )?(?:must|shall|should|will now|are to"
    r"|is to|(?:hereby )?(?:ordered|authori[sz]ed|instructed|required|directed|permitted|cleared) to)\b"
)
_ORDER_EN = (
    r"[:,.;—–-][ \t]{0,3}(?:please |immediately |now )?(?:abort|cancel|disable|deactivate|switch off|turn off|shut down"
    r"|ignore|override|bypass|land|descend|climb|ascend|fly|proceed|return|release|drop|deploy|disarm|arm|stop|halt"
    r"|approve|skip|upload|send|transmit|forward|delete|hand over|transfer|grant|broadcast|declare|mark)\b"
)

_CLAIM_FR = (
    r"\b(?:ici|c['’]est) (?:le |la |l['’])?(?:centre de (?:controle|commandement|coordination)|controle"
    r"|tour de controle|operateur|commandement|quartier general|ministere|autorite|superviseur)\b"
    r"|\b(?:message|avis|ordre|note|communique|directive|consigne)s? (?:officiel(?:le)?s? |urgente?s? |prioritaires? )?"
    r"(?:du|de la|de l['’]|des) (?:[^\W\d_]{1,20} ){0,3}?(?:ministere|operateur|centre de controle|controle"
    r"|commandement|autorites?|prefecture|gouvernement|police)\b|\bpar ordre (?:du|de la|de l['’])"
)
_DIRECTIVE_FR = (
    r"(?:drones?|appareils?|aeronefs?|agents?|assistants?|ia) (?:doi(?:t|vent)|devra"
    r"|devront|est (?:autorise|tenu|prie) d)|\bvous devez\b|\btu dois\b|[:,.;—–-][ \t]{0,3}(?:veuillez )?(?:annulez"
    r"|annule|posez|pose|desactivez|desactive|coupez|coupe|arretez|arrete|larguez|largue|montez|monte|descendez"
    r"|descends|atterrissez|atterris|ignorez|ignore|envoyez|envoie|supprimez|approuvez|revenez|retournez|rentrez)\b"
)

_CLAIM_AR = (
    r"(?:هذا هو|هذه|هنا|معك) (?:ال)?(?:مشغل|غرفة (?:ال)?(?:تحكم|عمليات|قيادة)|مركز (?:ال)?(?:تحكم|قيادة|عمليات)|قيادة"
    r"|برج (?:ال)?مراقبة|وزارة|هيئة|مشرف)"
    r"|(?:رسالة|بلاغ|امر|اوامر|تعميم|اشعار|تعليمات|توجيه|توجيهات)(?: رسمية| رسمي| عاجلة| عاجل)? "
    r"(?:من|صادرة عن|صادر عن) "
    r"(?:ال)?(?:مشغل|غرفة|مركز|قيادة|وزارة|هيئة|برج|مشرف|سلطات|جهات|ادارة)|بامر من|بناء على (?:امر|اوامر|تعليمات) "
    r"(?:ال)?(?:وزارة|قيادة|مشغل|هيئة)"
)
_DIRECTIVE_AR = (
    r"(?:على|يجب على|يتعين على|ايتها|ايها) (?:ال)?(?:طائرة|طائرات|درون|مسيرة|وكيل|مساعد|نظام)"
    r"|(?:^|[\s:،.؛—-])[وف]?(?:الغ|الغي|اوقف|اوقفي|عطل|اهبط|اهبطي|توجه|حلق|اطلق|تجاهل|ارسل|احذف|اقلع|ارتفع|توقف|انزل)"
    r"(?![^\W\d_])"
)

_CLAIM_UR = (
    r"یہ (?:کنٹرول روم|کنٹرول|آپریٹر|کمانڈ|ہیڈکوارٹر|وزارت|اتھارٹی)"
    r"|(?:کنٹرول روم|آپریٹر|کمانڈ|ہیڈکوارٹر|وزارت(?: [^\s]{1,15})?|اتھارٹی|حکومت|پولیس) (?:کی طرف سے|کا|کی)"
    r"(?: سرکاری| فوری)? ?(?:پیغام|حکم|ہدایت|ہدایات|اطلاع|نوٹس)?|سرکاری (?:پیغام|حکم|نوٹس)"
)
_DIRECTIVE_UR = (
    r"(?:منسوخ|بند|روک|نظر ?انداز) (?:کریں|کرے|کرو|کر دیں|کر دے|کر دو|دیں|دے)|اتار (?:دیں|دے|دو)|پرواز (?:کرے|کریں|کرو)"
    r"|(?:چھوڑ|بھیج) (?:دیں|دے|دو)|ڈرون (?:کو )?(?:فوراً|فورا|ابھی)"
)

_CLAIM_ZH = (
    r"这里是(?:指挥中心|控制中心|控制室|操作员|塔台|总部|地面站|地面控制|管理局|民航局|公安局)"
    r"|(?:民航局|公安部|内政部|指挥中心|控制中心|操作员|管理局|总部|指挥部|政府|塔台|地面控制)的?(?:正式|紧急|官方|最新)?"
    r"(?:通知|命令|指令|消息|通告)|奉[^。\n]{1,12}(?:命令|指示)"
)
_DIRECTIVE_ZH = (
    r"无人机(?:必须|应当|应|需要|须|立即)|你(?:必须|需要|应该|应当|须)"
    r"|(?:取消|关闭|降落|停止|释放|飞往|返回|忽略|解除|禁用)(?:当前|所有|地理|载荷|任务|拍摄|录像)"
)

_AUTHORITY = rules(
    "override",
    (
        "authority_order",
        _CLAIM_EN,
        "this here it message notice order orders directive directives instruction instructions communication"
        " communications notification notifications alert alerts bulletin bulletins memo memos transmission"
        " transmissions by behalf control command hq headquarters ops tower operator",
        0.75,
    ),
    (
        "authority_order_fr",
        _CLAIM_FR,
        "ici est message messages avis ordre ordres note notes communique communiques directive directives consigne"
        " consignes par",
        0.75,
    ),
    ("authority_order_ar", _CLAIM_AR, "هذا هذه هنا معك من عن بامر بناء", 0.75),
    ("authority_order_ur", _CLAIM_UR, "یہ کا کی سرکاری", 0.75),
    ("authority_order_zh", _CLAIM_ZH, "这里是 通知 命令 指令 消息 通告 奉", 0.75),
)
_DIRECTIVES = (rf"{_ADDRESSEE_EN}|{_ORDER_EN}", _DIRECTIVE_FR, _DIRECTIVE_AR, _DIRECTIVE_UR, _DIRECTIVE_ZH)
AUTHORITY = tuple(_ordered(rule, directive) for rule, directive in zip(_AUTHORITY, _DIRECTIVES, strict=True))

# --- role-play ------------------------------------------------------------------------------------------------------
_CUE_EN = (
    r"(?:no|without (?:any )?)(?:safety |ethical )?(?:rules|limits|restrictions|filters|guardrails|constraints"
    r"|approval)"
    r"|unrestricted|unfiltered|unaligned|uncensored|jailbr|\bdan\b|\boperator\b|ground station|\bai\b|\bagent\b"
    r"|\bmodel\b|never asks|ignores?\b|anything"
)
_CUE_FR = (
    r"sans (?:aucune? )?(?:restriction|limite|regle|contrainte|filtre)|\bdan\b|ne respecte plus|aucune regle|debride"
)
_CUE_AR = r"(?:بدون|بلا|دون) (?:اي )?(?:قيود|حدود|قواعد)|لا (?:يلتزم|تلتزم) ب|dan|غير مقيد|مساعد|وكيل|نموذج|شخصية"
_CUE_UR = r"(?:کوئی|کسی) (?:پابندی|حفاظتی اصول|اصول|قاعدے)|dan|بغیر (?:کسی )?(?:پابندی|روک)"
_CUE_ZH = r"没有任何限制|不受[^。\n]{0,8}(?:限制|约束)|无限制|dan|不遵守|无视[^。\n]{0,4}规则"

ROLE_PLAY = rules(
    "override",
    (
        "pretend_you",
        r"\b(?:pretend|act like|make believe) (?:that )?(?:you(?:'re| are| were)|to be)\b",
        "pretend act make",
        _boosted(_CUE_EN, 0.75, 0.55),
        "neg",
    ),
    (
        "imagine_you",
        r"\b(?:imagine|suppose|assume|picture) (?:that )?you(?:'re| are| were) (?:an?|the|now)\b",
        "imagine suppose assume picture",
        _boosted(_CUE_EN, 0.7, 0.35),
        "neg",
    ),
    (
        "play_a_game",
        r"\blet(?:'s| us) play a game\b|\bin this game,? you\b|\bstay in character\b|\bnever break character\b"
        r"|\bfor the rest of this (?:conversation|chat|session),? you (?:are|will be)\b",
        "play game character rest",
        0.55,
    ),
    (
        "named_persona",
        r"\byou(?:'re| are) (?:now )?[a-z][a-z0-9_-]{2,20}, an? (?:[a-z-]{1,20} ){0,2}(?:ai|drone|agent|assistant"
        r"|model|pilot|bot|chatbot)\b",
        "ai drone agent assistant model pilot bot chatbot",
        0.6,
    ),
    (
        "roleplay_as",
        r"\b(?:role-?play|role play) as\b|\bplay the (?:role|part) of\b|\btake on the (?:role|persona) of\b"
        r"|\bassume the (?:role|persona|identity) of\b",
        "roleplay role play take assume",
        _boosted(_CUE_EN, 0.75, 0.45),
        "neg",
    ),
    (
        "act_as_my",
        r"\b(?:act|behave|respond|speak|pose) as (?:if you were )?my\b",
        "act behave respond speak pose",
        _boosted(r"codes?\b|passwords?|secrets?|keys?\b|override|rules|no limits", 0.7, 0.45),
    ),
    (
        "override_code",
        r"\b(?:override|authori[sz]ation|access|admin|master) code[\W_]{1,3}\w{2,12}[\W_]{1,3}(?:accepted|verified"
        r"|confirmed|granted|valid)\b",
        "code",
        0.55,
    ),
    (
        "no_approval",
        r"\bno (?:operator |human )?(?:confirmation|approval|authori[sz]ation)s? (?:is |are )?(?:required|needed"
        r"|necessary)\b|\bwithout (?:operator |human |any )?(?:approval|confirmation)\b",
        "no without",
        0.35,
    ),
    (
        "limitless_persona",
        r"\b(?:an?|the) (?:ai|drone|agent|assistant|model|pilot|uav|bot)(?: [a-z]{1,15})? (?:with no|without (?:any )?)"
        r"(?:safety |ethical )?(?:rules|limits|restrictions|filters|guardrails|constraints)\b"
        r"|\b(?:unaligned|unrestricted|uncensored) (?:ai|agent|drone|assistant|model|pilot)\b",
        "ai drone agent assistant model pilot uav bot unaligned unrestricted uncensored",
        0.5,
    ),
    (
        "roleplay_fr",
        r"\b(?:fais|faites|fait) semblant d['’]?etre|\bimagine[zs]? que (?:tu es|vous etes)|\bjou(?:e|ez) le role d"
        r"|\bprends le role d|\b(?:a partir de maintenant|desormais|dorenavant),? (?:tu es|vous etes)"
        r"|\b(?:tu es|vous etes) maintenant\b|\btu n['’]es plus\b",
        "fais faites fait imagine imaginez imagines joue jouez prends partir desormais dorenavant maintenant plus",
        _boosted(_CUE_FR, 0.75, 0.55),
    ),
    (
        "roleplay_ar",
        r"(?:تظاهر|تظاهري|تخيل|تخيلي|افترض) (?:ب)?(?:انك|أنك)|(?:العب|قم ب|مثل) دور|من الان (?:فصاعدا )?(?:انت|ستكون)",
        "تظاهر تخيل افترض دور الان",
        _boosted(_CUE_AR, 0.75, 0.55),
    ),
    ("you_are_now_ar", r"(?<![^\W_])انت الان", "انت", _boosted(_CUE_AR, 0.75, 0.35)),
    (
        "roleplay_ur",
        r"(?:فرض|ظاہر|بہانہ) (?:کرو|کریں|کیجیے) کہ (?:تم|آپ)|(?:کا|کی) کردار ادا (?:کرو|کریں)",
        "فرض ظاہر بہانہ کردار",
        _boosted(_CUE_UR, 0.75, 0.55),
    ),
    (
        "you_are_now_ur",
        r"(?<![^\W_])اب (?:تم|آپ) [^\n]{0,30}?(?:ہو|ہیں)(?![^\W_])",
        "اب",
        _boosted(_CUE_UR, 0.75, 0.35),
    ),
    (
        "roleplay_zh",
        r"(?:假装|假扮)你是|从现在(?:开始|起)[,，]?你(?:是|就是|将是)|你现在是|请?扮演(?:一个|一名|一架)|角色扮演",
        "假装 假扮 从现在 你现在是 扮演",
        _boosted(_CUE_ZH, 0.75, 0.55),
    ),
    ("suppose_zh", r"(?:想象|假设|设想)你是", "想象 假设 设想", _boosted(_CUE_ZH, 0.7, 0.35)),
)

__all__ = ["AUTHORITY", "ROLE_PLAY"]
