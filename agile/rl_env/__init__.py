"""Manager-based RL environment.

`ManagerBasedRLEnv` and its config are imported when first named: importing a light submodule such as
`agile.rl_env.io_descriptor_file` (what `agile deploy` and `agile sim2mujoco` read) then costs no simulator import."""

__all__ = ["ManagerBasedRLEnv", "ManagerBasedRLEnvCfg"]


def __getattr__(name: str):
    if name in __all__:
        from agile.rl_env import env

        return getattr(env, name)
    raise AttributeError(f"module 'agile.rl_env' has no attribute {name!r}")
