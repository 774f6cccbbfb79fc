"""Adapters of :class:`orbit_rs.OrbitVectorEnv` for learning libraries, after Isaac Lab's
``isaaclab_rl``: :mod:`.rsl_rl` (RSL-RL's ``VecEnv``), :mod:`.sb3` (Stable-Baselines3's
``VecEnv``) and :mod:`.skrl` (an skrl env wrapper). Each imports its library only when used."""
