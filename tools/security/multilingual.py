"""The injection guard's overrides in the scenario's other languages (French, Arabic, Urdu, Chinese): instructions
to forget the earlier ones, "new system instructions", and orders to switch off the aircraft's safety limits.

English and the first few of these live in ``patterns`` (``OVERRIDE``); these follow the same conventions: written
in their own script, run on the folded view (Urdu letters read as Arabic ones, no diacritics), bounded quantifiers.
"""

from __future__ import annotations

from .patterns import either, rules

MULTILINGUAL = rules(
    "override",
    (
        "ignore_ur",
        r"(?:پچھلی|سابقہ|پہلے کی|تمام|اپنی|سب|ساری|گزشتہ)[^\n۔]{0,20}?(?:ہدایات|ہدایت|احکامات|احکام|اصول|قواعد)"
        r"[^\n۔]{0,12}?(?:نظر ?انداز|بھول|مت مان|نہ مان|ترک)",
        "ہدایات ہدایت احکامات احکام اصول قواعد",
        0.85,
    ),
    (
        "forget_told_ar",
        r"(?:انس|تجاهل|اهمل)[^\n.]{0,6}(?:كل )?(?:ما قيل لك|ما سبق|ما تعلمته|ما طلب منك)",
        "انس تجاهل اهمل",
        0.8,
    ),
    (
        "new_instructions_ar",
        r"(?:تعليمات|اوامر|توجيهات) (?:ال)?(?:جديدة|سرية|حقيقية|نظام الجديدة)(?: لل?نظام)?\s*[:：]",
        "تعليمات اوامر توجيهات",
        0.6,
    ),
    (
        "disable_safety_ar",
        r"(?:تجاهل|عطل|اوقف|الغ|تخط)[^\n]{0,6}(?:حدود الارتفاع|السياج الجغرافي|قواعد الامان|انظمة الامان|نظام تجنب"
        r"|الحد الاقصى للارتفاع)",
        "تجاهل عطل اوقف الغ تخط",
        0.6,
    ),
    (
        "new_instructions_fr",
        r"\b(?:nouvelles?|vraies?|veritables?) (?:instructions|consignes|directives)(?: du)?(?: systeme)?[ \t]*:",
        "nouvelle nouvelles nouvel vraie vraies veritable veritables",
        either("systeme", 0.7, 0.4),
    ),
    (
        "disable_safety_fr",
        r"\b(?:desactive[zr]?|coupe[zr]?|ignore[zr]?|contourne[zr]?) (?:la |le |les )?(?:geobarriere|geo-barriere"
        r"|barriere virtuelle|limites? d['’]altitude|plafond|evitement d['’]obstacles|securites?|regles de securite)\b",
        "desactive desactivez desactiver coupe coupez couper ignore ignorez ignorer contourne contournez contourner",
        0.6,
    ),
    (
        "new_instructions_zh",
        r"新的?(?:系统)?(?:指令|指示|命令)[:：]|系统(?:指令|提示)[:：]",
        "新 系统",
        either("系统", 0.6, 0.4),
    ),
    (
        "disable_safety_zh",
        r"(?:关闭|禁用|解除|忽略|绕过)(?:地理围栏|电子围栏|高度限制|限高|安全(?:规则|限制|检查)|避障)",
        "关闭 禁用 解除 忽略 绕过",
        0.6,
    ),
    ("no_approval_zh", r"不再需要(?:操作员)?(?:的)?(?:批准|确认|审批)", "不再需要", 0.5),
)

__all__ = ["MULTILINGUAL"]
