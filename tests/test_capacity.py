"""Peak constraint rows and contacts, counted on the device (agile/sim/capacity.py)."""

import torch

from agile.sim import SimCfg
from agile.sim.sim_cfg import SolverCfg
from scenes import robot_sim
from test_terrain import BOX_XML, STAIRS
from agile.sim import ArticulationCfg


def box_on_stairs(tmp_path, njmax: int):
    path = tmp_path / "box.xml"
    path.write_text(BOX_XML)
    return robot_sim(ArticulationCfg(model_file=str(path), init_pos_m=(0.0, 0.0, 0.12)), 2,
                     sim=SimCfg(use_graph=False, solver=SolverCfg(njmax=njmax)), terrain=STAIRS)


def test_peaks_count_a_resting_box_and_overflows_past_njmax(tmp_path):
    sim = box_on_stairs(tmp_path, njmax=100)
    sim.step(40)
    cap = sim.capacity
    # a box resting on the platform: 4 corners and the samples under its 0.2 m x 0.2 m bottom (3 x 3), pyramidal
    # friction cones of 4 rows per contact
    rows = int(cap.peak_constraint_rows.item())
    assert rows % 4 == 0 and 4 * 4 <= rows <= 4 * (4 + 9)
    assert cap.constraint_row_overflows.item() == 0
    assert 2 * 4 <= cap.peak_contacts.item() <= cap.contact_capacity
    log = cap.log()
    assert torch.isclose(log["Physics/peak_constraint_rows_share_of_njmax"], torch.tensor(rows / 100))
    # the same box with room for fewer rows than it needs: every world-step counts
    small = box_on_stairs(tmp_path, njmax=8)
    small.step(40)
    # MuJoCo Warp counts the rows a world asks for past the cap: the peak is the demand, not the cap
    assert small.capacity.peak_constraint_rows.item() == rows
    assert 0 < small.capacity.constraint_row_overflows.item() <= 2 * 40
    small.capacity.clear()
    assert small.capacity.constraint_row_overflows.item() == 0 and small.capacity.peak_constraint_rows.item() == 0
