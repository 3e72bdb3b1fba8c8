"""Training the ``ppo`` policy (offroadbench.navigation.policies.ppo): not on the run-time path.

:mod:`.pool` is a Gymnasium env over a pool of terrains (one TraverseEnv each, episodes in turn)
whose observation is the ppo policy's feature vector and whose action is normalised to [-1, 1]^2:
what ``experiments/train_ppo.py`` trains stable-baselines3's PPO on (the ``rl`` extra). Nothing here
is imported by a trial; the trained policy runs on numpy alone.
"""
