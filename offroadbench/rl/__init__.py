"""Training the ``ppo`` policy (offroadbench.navigation.policies.ppo): not on the run-time path.

* :mod:`.pool`: a Gymnasium env over a pool of terrains (one TraverseEnv each, episodes in turn),
  whose observation is the ppo policy's feature vector and whose action is normalised to [-1, 1]^2;
* :mod:`.ppo_numpy`: PPO (Schulman et al. 2017) with GAE (Schulman et al. 2016) and Adam (Kingma &
  Ba 2015) in numpy, for the small MLP of the ppo policy.

Run by ``experiments/train_ppo.py``. Nothing here is imported by a trial.
"""
