"""somite as Gymnasium environments (the optional extra ``somite[gym]``).

``somite/Locomotion-v0`` (:mod:`somite.envs.locomotion`) is one robot's locomotion episode;
its vector form (:mod:`somite.envs.vector`) steps N robots in one compiled batch call.
:func:`somite.policy` (:mod:`somite.envs.policy`) runs an evolved genome as a policy in either.
Importing somite registers the environment with Gymnasium once Gymnasium is imported
(:func:`register`); this package imports Gymnasium only in the modules that need it.
"""

ENV_ID = "somite/Locomotion-v0"


def register() -> None:
    """Register ``somite/Locomotion-v0`` (and its vector entry point) with Gymnasium, once."""
    from gymnasium.envs.registration import register as gym_register
    from gymnasium.envs.registration import registry

    if ENV_ID not in registry:
        gym_register(id=ENV_ID, entry_point="somite.envs:make_env",
                     vector_entry_point="somite.envs.vector:LocomotionVectorEnv")


def make_env(**kwargs):
    """The entry point ``gymnasium.make`` calls: a function, not the class, so that Gymnasium
    hands ``render_mode`` over as given. Given the class, it turns ``"human"`` into
    ``"rgb_array"`` behind a pygame window (its HumanRendering), which somite neither needs nor
    installs: the environment refuses ``"human"`` in one line instead. ``"rgb_array_list"``
    gives Gymnasium's RenderCollection, as it would."""
    from .locomotion import LocomotionEnv

    if kwargs.get("render_mode") == "rgb_array_list":
        from gymnasium.wrappers import RenderCollection

        return RenderCollection(LocomotionEnv(**{**kwargs, "render_mode": "rgb_array"}))
    return LocomotionEnv(**kwargs)


__all__ = ["ENV_ID", "make_env", "register"]
