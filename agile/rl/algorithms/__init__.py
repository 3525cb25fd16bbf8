"""The learning algorithms on rsl-rl: PPO's extensions (sync-free and captured updates, entropy annealing, reward
normalisation, L2C2) and distillation with a mirror loss."""
