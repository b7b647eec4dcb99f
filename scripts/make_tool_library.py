#!/usr/bin/env python3
"""Writes assets/tools/default.toml, the shipped tool library, from the rules below.

    python3 scripts/make_tool_library.py > assets/tools/default.toml

Geometry follows catalogue carbide end mills: flutes 3 D long (at least 3 mm), a 3 mm
shank below 3 mm diameter (the shank of the cutting diameter above), a stick-out of the
flute length plus 2 D plus 6 mm, in an ER20 collet chuck (nut 35 mm across, 40 mm long).
Cutting data per material: a surface speed and a chip load per tooth proportional to the
diameter (within a floor and a ceiling), with axial and radial depth limits in diameters,
from the usual starting values of carbide tool makers' charts for slotting.

Long-reach end mills (T31-T34) have flutes 1.5 D long, a relieved neck 0.95 D wide up to
their reach (10, 12 and 16 mm for 1, 2 and 3 mm, and T34, a 2 mm one to 25 mm, 12.5 D,
for slots under 4 mm wide and over 16 mm deep, such as example007's 4 mm cross slots 22 mm
below its top), then a 4 or 6 mm shank, 10 mm of it out of the chuck; their cutting data are conservative: 0.8 times the surface speed, half the
chip load and half the axial depth of the short tools'.

T-slot cutters (T41-T42, DIN 851 sizes) are discs as thick as their flute length on a
neck under the slot's width, reaching 30 and 20 mm from the tip, then a shank 10 mm out of
the chuck; they cut undercuts from the side (entered at a slot's open end). Their cutting
data are conservative: 0.6 times the surface speed and half the chip load of a flat end
mill of the disc's diameter, the axial depth the disc's thickness, a quarter of the
diameter radially.
"""

import math

FLATS = [1, 2, 3, 4, 5, 6, 8, 10, 12]
BALLS = [1, 2, 3, 4, 6, 8, 10]
BULLS = [(6, 0.5), (10, 1.0)]
# Long-reach (necked) flat end mills: diameter, reach (tip to the neck's top), shank.
LONG = [(1, 10.0, 4.0), (2, 12.0, 4.0), (3, 16.0, 6.0), (2, 25.0, 4.0)]
# T-slot cutters: disc diameter, thickness, neck diameter, reach, shank, teeth.
TSLOTS = [(21.0, 9.0, 10.0, 30.0, 12.0, 6), (12.5, 6.0, 6.0, 20.0, 10.0, 6)]

# name, description, coolant, vc (m/min), fz per mm of diameter, fz floor, fz ceiling,
# ap (D), ae (D), plunge ratio.
MATERIALS = [
    ("aluminium-6061", "Aluminium 6061-T6", "flood", 250.0, 0.006, 0.005, 0.08, 1.0, 0.5, 0.3),
    ("mild-steel", "Mild steel (S235, 1018)", "flood", 100.0, 0.003, 0.003, 0.05, 0.5, 0.3, 0.25),
    ("pom", "POM / acetal (Delrin)", "none", 200.0, 0.008, 0.01, 0.12, 1.0, 0.5, 0.4),
    ("wax", "Machining wax", "none", 150.0, 0.01, 0.01, 0.15, 1.5, 0.6, 0.5),
]


def num(v):
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return s if "." in s else s + ".0"


def cutting(d, long=False, disc=None):
    lines = []
    for name, _, _, vc, fzk, lo, hi, ap, ae, plunge in MATERIALS:
        fz = min(hi, max(lo, fzk * d))
        if long:
            vc, fz, ap = 0.8 * vc, 0.5 * fz, 0.5 * ap
        if disc is not None:
            vc, fz, ap, ae = 0.6 * vc, 0.5 * fz, math.floor(1e4 * disc / d) / 1e4, 0.25
        lines.append(
            f"{name} = {{ vc = {num(vc)}, fz = {num(fz)}, ap = {num(ap)}, ae = {num(ae)}, plunge = {num(plunge)} }}"
        )
    return lines


def tool(number, name, shape, d, flutes, corner=None, neck=None, disc=None):
    """A tool; `neck` is (reach, shank), `disc` a T-slot cutter's (thickness, neck diameter)."""
    flute = max(3.0, 3.0 * d)
    shank = 3.0 if d < 3 else d
    stickout = flute + 2.0 * d + 6.0
    neck_d = 0.95 * d
    if neck is not None:
        reach, shank = neck
        flute = 1.5 * d
        stickout = reach + 10.0
    if disc is not None:
        flute, neck_d = disc
    out = ["[[tool]]", f"number = {number}", f'name = "{name}"', f'shape = "{shape}"', f"diameter = {num(d)}"]
    if corner is not None:
        out.append(f"corner_radius = {num(corner)}")
    out += [
        f"flutes = {flutes}",
        f"flute_length = {num(flute)}",
        f"stickout = {num(stickout)}",
        f"shank_diameter = {num(shank)}",
        "holder = { diameter = 35.0, length = 40.0 }",
    ]
    if neck is not None:
        out.append(f"neck = {{ diameter = {num(neck_d)}, reach = {num(neck[0])} }}")
    out += [
        "",
        "[tool.cutting]",
    ]
    out += cutting(d, neck is not None and disc is None, None if disc is None else disc[0])
    return "\n".join(out) + "\n"


HEADER = """\
# Shape2Gcode's default tool library: carbide end mills in an ER20 collet chuck.
# Made by scripts/make_tool_library.py (its docstring gives the rules); edit that, or copy
# this file and edit the copy, and pass it with `s2g mill --tools FILE`.
#
# Units: millimetres; surface speed in m/min.
#
# [machine]                     the machine the tools are fitted to (every field optional)
#   name, max_feed (mm/min), rapid (mm/min per axis X, Y, Z), accel (mm/s^2 per axis),
#   junction_deviation (mm, as grbl's $11), spindle_rpm ([min, max]), tool_change_s,
#   lookahead (blocks the trajectory planner plans ahead)
#
# [[material]]                  one per workpiece material
#   name          the key tools' cutting data refer to (`s2g mill --material NAME`)
#   description   free text
#   coolant       "flood" (M8), "mist" (M7) or "none"
#   fallback      optional cutting data for tools without their own for this material
#                 (tools imported from a LinuxCNC tool table or FreeCAD bits): as below,
#                 with fz per mm of diameter
#
# [[tool]]                      one per cutter
#   number        T and H word (1 or more, unique)
#   name          free text
#   shape         "flat", "ball", "bull" or "tslot" (a T-slot cutter: a disc, the flutes,
#                 flute_length thick, on a neck narrower than it, which it must have;
#                 it cuts undercuts from the side, never roughs or finishes from above)
#   diameter      cutting diameter
#   corner_radius bull only: the torus radius (0 < corner_radius <= diameter / 2)
#   flutes        number of teeth
#   flute_length  cutting length from the tip
#   stickout      tip to the holder's face (>= flute_length)
#   shank_diameter
#   holder        optional { diameter, length }: the chuck's cylinder above the stick-out
#   neck          optional { diameter, reach }: a long-reach end mill's relieved neck, not
#                 cutting, no wider than the flutes, from their top up to `reach` above the
#                 tip (flute_length < reach <= stickout); the shank starts there. A
#                 LinuxCNC tool table has no neck column: the table s2g writes holds the
#                 cutting diameter, the name (which says the reach) as its comment (a
#                 T-slot cutter's too: its neck and thickness are in the name)
#   [tool.cutting] per material name:
#     vc          surface speed, m/min: spindle rpm = 1000 vc / (pi D), within the
#                 machine's spindle range
#     fz          chip load per tooth, mm: feed = fz * flutes * rpm, within the machine's
#                 largest feed
#     ap          largest axial depth of cut, in diameters
#     ae          largest radial depth of cut (stepover), in diameters (at most 1)
#     plunge      plunge and ramp feed as a fraction of the feed (default 0.3)
"""


def main():
    parts = [
        HEADER,
        "\n".join(
            [
                "[machine]",
                'name = "generic-router"',
                "max_feed = 5000.0",
                "rapid = [5000.0, 5000.0, 5000.0]",
                "accel = [500.0, 500.0, 300.0]",
                "junction_deviation = 0.01",
                "spindle_rpm = [1000.0, 24000.0]",
                "tool_change_s = 10.0",
                "lookahead = 32",
            ]
        )
        + "\n",
    ]
    for name, desc, coolant, vc, fzk, lo, hi, ap, ae, plunge in MATERIALS:
        parts.append(
            "\n".join(
                [
                    "[[material]]",
                    f'name = "{name}"',
                    f'description = "{desc}"',
                    f'coolant = "{coolant}"',
                    f"fallback = {{ vc = {num(vc)}, fz = {num(fzk)}, ap = {num(ap)}, ae = {num(ae)}, plunge = {num(plunge)} }}",
                ]
            )
            + "\n"
        )
    n = 1
    for d in FLATS:
        parts.append(tool(n, f"{num(d).rstrip('0').rstrip('.')} mm flat end mill, 3 flutes", "flat", d, 3))
        n += 1
    n = 11
    for d in BALLS:
        parts.append(tool(n, f"{num(d).rstrip('0').rstrip('.')} mm ball end mill, 2 flutes", "ball", d, 2))
        n += 1
    n = 21
    for d, r in BULLS:
        parts.append(tool(n, f"{d} mm bull nose end mill, r{num(r)}, 4 flutes", "bull", d, 4, r))
        n += 1
    n = 31
    for d, reach, shank in LONG:
        name = f"{d} mm long-reach flat end mill, neck {num(0.95 * d)} mm to {reach:g} mm, 3 flutes"
        parts.append(tool(n, name, "flat", d, 3, neck=(reach, shank)))
        n += 1
    n = 41
    for d, t, nd, reach, shank, z in TSLOTS:
        name = f"{num(d).rstrip('0').rstrip('.')} x {t:g} mm T-slot cutter, neck {nd:g} mm to {reach:g} mm, {z} teeth"
        parts.append(tool(n, name, "tslot", d, z, neck=(reach, shank), disc=(t, nd)))
        n += 1
    print("\n".join(parts), end="")


if __name__ == "__main__":
    main()
