"""Registration of the gymnasium environments (``vfs/AEB-v0``).

Called when ``vfs`` is imported; the environments live in
:mod:`vfs.gym.env` and are imported only when one is made.
"""

from __future__ import annotations

#: Id of the AEB environment.
ENV_ID = "vfs/AEB-v0"


def register_envs() -> None:
    """Register ``vfs/AEB-v0`` (entry point :class:`vfs.gym.env.AEBEnv`, vector entry point
    :class:`vfs.gym.env.AEBVectorEnv`) with gymnasium; idempotent; a no-op without
    gymnasium.
    """
    try:
        from gymnasium.envs.registration import register, registry
    except ImportError:  # pragma: no cover - gymnasium is a dependency
        return
    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="vfs.gym.env:AEBEnv",
                 vector_entry_point="vfs.gym.env:AEBVectorEnv")
