"""Minimal reproduction: MuJoCo Warp's box / height-field collision gives a contact whose normal
points into the ground (docs/mujoco-warp.md, 'Not done' item 5). MuJoCo and MuJoCo Warp only, no
offroadbench code:

    python benchmarks/repro_mjwarp_hfield_box.py

A box (the Husky's chassis, half-extents 0.4937 x 0.28545 x 0.12375 m) rests with its front
bottom edge 7 mm into one 5 cm cell of a height field (2 x 2 samples, elevation and base 3.84 m:
engines-warp cell 3, terrain 1, column 583, row 585, at MuJoCo step 1865 of mission 7). MuJoCo 4.0.0
(``mj_forward``) gives the box 2 contacts, the deepest 7.1 mm, normals level or up. MuJoCo Warp 4.0
(``collision``, Warp's CPU device, float32) gives 2: one of those and one 0.2297 m deep with normal
(0, 0, -1) at a point 10 cm beyond the cell, whose witness points are the prism's top sample (0.502 m)
and the box's top face (0.732 m): a separation read as a penetration. The same pose against a 36 x 23
sample patch gives it too; with the base at 0.01-2 m (same cell) it does not. A sphere (a wheel) gets
one too, with normal (0, 0, 1) (tests/sim/test_mujoco_warp_contacts.py). The workaround in
offroadbench: before the constraint rows are made, drop every height-field contact whose normal
points down or whose terrain-side witness point lies above the terrain
(offroadbench/sim/engines/mujoco_warp/kernels.py, drop_false_contacts).
"""

from __future__ import annotations

import numpy as np


def main() -> None:
    import mujoco
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING
    import mujoco_warp as mjw

    data = [0.1283283680677414, 0.1109330877661705, 0.13083085417747498, 0.11497672647237778]  # row-major
    xml = """<mujoco><option ccd_iterations="10"/>
      <asset><hfield name="h" nrow="2" ncol="2" size="0.025 0.025 3.84 3.84"/></asset>
      <worldbody><geom type="hfield" hfield="h" pos="29.175 29.275 0"/>
        <body><freejoint/><geom type="box" size="0.4937 0.28545 0.12375" mass="1"/></body>
      </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    m.hfield_data[:] = data
    qpos = [29.604142171064552, 29.016955309422062, 0.6068023670173319, 0.10088833626607184,
            -0.00044522437911116356, -0.002876413599320458, 0.994893497629531]
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    print(f"MuJoCo {mujoco.__version__}: {d.ncon} contacts")
    for c in d.contact[:d.ncon]:
        print(f"  dist {c.dist:+.4f} m  pos {np.round(c.pos, 3)}  normal {np.round(c.frame[:3], 3)}")
    wm = mjw.put_model(m)
    wd = mjw.make_data(m, nworld=1, nconmax=16, njmax=64)
    wd.qpos.assign(np.array([qpos], dtype=np.float32))
    mjw.kinematics(wm, wd)
    mjw.collision(wm, wd)
    n = int(wd.nacon.numpy()[0])
    print(f"MuJoCo Warp {mjw.__version__} ({wp.get_device()}): {n} contacts")
    for k in range(n):
        print(f"  dist {wd.contact.dist.numpy()[k]:+.4f} m  pos {np.round(wd.contact.pos.numpy()[k], 3)}  "
              f"normal {np.round(wd.contact.frame.numpy()[k][0], 3)}")


if __name__ == "__main__":
    main()
