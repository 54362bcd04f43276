"""The catalogue of widely used robot arms shipped as robot files in ``data/robots``.

The catalogue is a set of commercial arms described with their manufacturers' published kinematics
(Universal Robots CB3 and e-Series, ABB IRB 120 / IRB 140, KUKA KR 5 arc, KUKA LBR iiwa 14, Franka
Emika Panda, Kinova Gen3): flange frame, no tool, lengths in metres, finite joint limits on every
joint. Unlike the other robot files, which reproduce a particular document, these are meant for
benchmark studies over realistic arms. Every file cites its DH source and its limits source in its
header comment (and in ``source`` / ``limits_source``); ``data/robots/CATALOGUE.md`` tabulates them,
and ``tests/test_catalogue.py`` checks each file's forward kinematics against an independent
implementation and a published zero pose.
"""

from __future__ import annotations

CATALOGUE: tuple[str, ...] = (
    "ur3",
    "ur5",
    "ur10",
    "ur3e",
    "ur5e",
    "ur10e",
    "ur16e",
    "abb_irb120",
    "abb_irb140",
    "kuka_kr5_arc",
    "kuka_iiwa14",
    "franka_panda",
    "kinova_gen3",
)
