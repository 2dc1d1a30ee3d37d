"""Physical effects as plugins (see :mod:`vfs.effects.base`) and the built-in library."""

from vfs.effects.base import (
    ENTRY_POINT_GROUP,
    STAGES,
    Effect,
    EffectParameter,
    VelocityChange,
    apply_post_impact,
    call_post_impact,
    check_effects,
    effects_from_dicts,
    get_effect,
    hooks,
    parse_effect,
    register_effect,
    registered_effects,
    unregister_effect,
)
from vfs.effects.context import ContactContext, ImpactContext
from vfs.effects.library import BUILTIN_EFFECTS

__all__ = [
    "BUILTIN_EFFECTS", "ENTRY_POINT_GROUP", "STAGES", "ContactContext", "Effect",
    "EffectParameter", "ImpactContext", "VelocityChange", "apply_post_impact",
    "call_post_impact", "check_effects",
    "effects_from_dicts", "get_effect", "hooks", "parse_effect", "register_effect",
    "registered_effects", "unregister_effect",
]
