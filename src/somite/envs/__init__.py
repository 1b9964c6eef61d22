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
        gym_register(id=ENV_ID, entry_point="somite.envs.locomotion:LocomotionEnv",
                     vector_entry_point="somite.envs.vector:LocomotionVectorEnv")


__all__ = ["ENV_ID", "register"]
