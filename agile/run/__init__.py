"""The runtime as a plain Python API: build a task's env as training builds it, load a policy, fingerprint a
shipped policy's rollout. The scripts (and the `agile` command) are thin entry points to it."""
