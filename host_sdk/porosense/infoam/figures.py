"""Figures of the assembly guide, drawn from the designs, the print plans and the meshes.

Sections of the actuators come from their ``Design`` regions (coloured by target porosity);
sections of the fixtures are cuts through their meshes; the 3-D views render the meshes'
triangles. All lengths in mm. ``write_all(folder)`` writes every figure docs/assembly.md uses.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from porosense.files import save_figure
from porosense.infoam import design as D
from porosense.infoam.parts import SLEEVE_MM, build_part, cup_inner_diameter

POROSITY_CMAP = "viridis"
SLEEVE_COLOUR = "#1f77b4"
ELECTRODE_COLOUR = "#d95f02"
MARKER_COLOUR = "#e7298a"
PLA_COLOUR = "0.55"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _norm():
    from matplotlib import colors

    return colors.Normalize(0.0, 100.0)


def _region_patches(ax, design, axis: int = 0, dx: float = 0.0, dz: float = 0.0):
    """Draw the section through y = 0 (axis 0: x-z) of every region, coloured by porosity."""
    from matplotlib.patches import Rectangle

    plt = _plt()
    cmap, norm = plt.get_cmap(POROSITY_CMAP), _norm()
    for r in design.regions:
        for a, b in r.shape.spans(axis, 0.0):
            ax.add_patch(
                Rectangle(
                    (a + dx, r.z0 + dz),
                    b - a,
                    r.z1 - r.z0,
                    facecolor=cmap(norm(r.porosity)),
                    edgecolor="white",
                    linewidth=0.4,
                )
            )


def _mesh_cut(ax, mesh, normal=(0, 1, 0), origin=(0, 0, 0), transform=None, colour=PLA_COLOUR, label=None):
    """Outline of ``mesh`` cut by a plane, drawn in x-z (normal y) or y-z (normal x)."""
    import trimesh

    m = mesh.copy()
    if transform is not None:
        m.apply_transform(transform)
    seg = trimesh.intersections.mesh_plane(m, normal, origin)
    i = 0 if abs(normal[1]) > 0.5 else 1
    from matplotlib.collections import LineCollection

    ax.add_collection(LineCollection(seg[:, :, [i, 2]], colors=colour, linewidths=1.4, label=label))


def _move(x=0.0, y=0.0, z=0.0, flip=False):
    t = np.eye(4)
    if flip:  # turn over about the y axis: x -> -x, z -> -z (keeps the segment's C1 on +y)
        t[0, 0] = t[2, 2] = -1.0
    t[:3, 3] = (x, y, z)
    return t


def _colourbar(fig, axes):
    from matplotlib import cm

    plt = _plt()
    fig.colorbar(
        cm.ScalarMappable(norm=_norm(), cmap=plt.get_cmap(POROSITY_CMAP)),
        ax=axes,
        label="target porosity (%)",
        shrink=0.7,
    )


def contractor_assembly(path=None):
    """Contractor section with sleeve, electrodes, hanger, load hook and camera markers."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 7.2), layout="constrained")
    c = D.paper_contractor()
    h, r = D.CONTRACTOR_HEIGHT_MM, D.CONTRACTOR_DIAMETER_MM / 2
    _region_patches(ax, c)
    s = r + SLEEVE_MM
    ax.plot(
        [-s, -s, s, s, -s],
        [-SLEEVE_MM, h + SLEEVE_MM, h + SLEEVE_MM, -SLEEVE_MM, -SLEEVE_MM],
        color=SLEEVE_COLOUR,
        lw=1.2,
        label=f"SEBS sleeve {SLEEVE_MM:g} mm, heat-sealed",
    )
    # The hanger is printed floor down and used floor up: turn it over onto the top end.
    hanger = build_part("contractor_hanger").mesh
    floor = h + SLEEVE_MM + 4.0  # the hanger's 4 mm floor rests on the sleeved top
    _mesh_cut(ax, hanger, transform=_move(z=floor, flip=True), label="PLA hanger / load hook")
    hook = build_part("contractor_load_hook").mesh
    _mesh_cut(ax, hook, transform=_move(z=D.CONTRACTOR_END_MM - SLEEVE_MM, flip=True))
    # Electrodes: a wire pushed 5 mm into each solid end, out through the cups' wire holes (at
    # x = -(cup radius - 2) once the printed parts are turned over).
    xw = -(cup_inner_diameter() / 2 - 2.0)
    ax.plot([xw, xw], [h - 5.0, floor + 10.0], color=ELECTRODE_COLOUR, lw=2.0)
    ax.plot([xw, xw], [5.0, -16.0], color=ELECTRODE_COLOUR, lw=2.0)
    ax.plot([], [], color=ELECTRODE_COLOUR, lw=2.0, label="copper-wire electrodes, 5 mm into each solid end")
    ax.plot(
        [0, 0],
        [h - D.CONTRACTOR_END_MM - 1.0, floor + 12.0],
        color="k",
        lw=3.0,
        label="vacuum tube through the hanger and the top's port into the foam",
    )
    rc = cup_inner_diameter() / 2 + 3.0
    for z in (2.5 - 4.0, h + 2.0):
        ax.plot([rc + 1.0], [z], "o", color=MARKER_COLOUR, ms=9, mec="k")
    ax.plot(
        [],
        [],
        "o",
        color=MARKER_COLOUR,
        ms=9,
        mec="k",
        label="camera markers on the two cups (they move with the solid ends)",
    )
    for z in D.CONTRACTOR_RING_Z_MM:
        ax.annotate(
            f"ring {z:g}-{z + D.CONTRACTOR_RING_MM:g} mm",
            (r, z + 2.8),
            (r + 6, z + 2.8),
            va="center",
            fontsize=8,
            arrowprops={"arrowstyle": "-"},
        )
    ax.annotate("load (200 g / 500 g)", (0, -20), (8, -26), fontsize=8, arrowprops={"arrowstyle": "->"})
    ax.set_xlim(-42, 48)
    ax.set_ylim(-32, h + 24)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("Contractor: section, sleeve, electrodes, hanger and load hook")
    ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(0.0, 1.06), ncol=1)
    _colourbar(fig, ax)
    return _save(fig, path)


def bending_assembly(path=None):
    """Bending actuator side view: holder, sleeve, electrodes, markers and stripes."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 4.4), layout="constrained")
    b = D.paper_bending()
    length, width, height = D.BENDING_BODY_MM
    top = D.BENDING_BASE_MM + height
    _region_patches(ax, b)
    x0, x1 = -length / 2, length / 2
    s = SLEEVE_MM
    ax.plot(
        [x0 - s, x0 - s, x1 + s, x1 + s, x0 - s],
        [-s, top + s, top + s, -s, -s],
        color=SLEEVE_COLOUR,
        lw=1.2,
        label=f"SEBS sleeve {s:g} mm, heat-sealed",
    )
    # The holder's slot starts 4 mm behind its back face: put the actuator's end there.
    holder = build_part("bending_holder").mesh
    _mesh_cut(ax, holder, transform=_move(x=x0 - s - 0.2 - 4.0, z=-4.0 - s - 0.2), label="PLA holder (section)")
    for (x, z), side in (((x0 + 1.5, top - 1.5), -1), ((x1 - 1.5, 1.5), 1)):
        ax.plot([x, x + side * 14.0], [z, z], color=ELECTRODE_COLOUR, lw=2.0)
    ax.plot([], [], color=ELECTRODE_COLOUR, lw=2.0, label="copper-wire electrodes: top-left, bottom-right")
    ax.plot([x0 - 22, x0 + 1], [top / 2, top / 2], color="k", lw=3.0, label="vacuum tube")
    for x in (x0, 0.0, x1):
        ax.plot([x], [0.5], "o", color=MARKER_COLOUR, ms=8, mec="k")
    ax.plot([], [], "o", color=MARKER_COLOUR, ms=8, mec="k", label="markers level with the base, 37.5 mm apart")
    for r in b.regions:
        if r.name.startswith("spacer_"):
            xm = (r.shape.x0 + r.shape.x1) / 2
            ax.plot([xm, xm], [D.BENDING_BASE_MM, top], color="k", lw=2.2, ls=(0, (1.5, 1.0)))
    ax.plot([], [], color="k", lw=2.2, ls=(0, (1.5, 1.0)), label="stripe on every spacer (side face)")
    ax.set_xlim(x0 - 24, x1 + 18)
    ax.set_ylim(-24, top + 8)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    fig.suptitle(
        f"Bending actuator: 1 mm base, {length:g} x {width:g} x {height:g} mm body of four "
        "84 % sections and four solid spacers"
    )
    ax.legend(loc="lower right", fontsize=7, ncol=2)
    _colourbar(fig, ax)
    return _save(fig, path)


def wiring(path=None):
    """Each actuator's divider: 5 V -> 1 kOhm -> ADS1115 input -> actuator -> GND."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    ax.set_axis_off()

    def resistor(x, y0, y1, label, colour="k"):
        ys = np.linspace(y0 + 0.25, y1 - 0.25, 13)
        xs = x + 0.18 * np.array([0, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, 0])
        ax.plot([x, x], [y0, y0 + 0.25], color=colour)
        ax.plot(xs, ys, color=colour)
        ax.plot([x, x], [y1 - 0.25, y1], color=colour)
        ax.text(x + 0.35, (y0 + y1) / 2, label, va="center", fontsize=9)

    for k, x in enumerate((1.0, 3.5, 6.0)):
        ax.plot([x, x], [5.0, 4.6], color="k")
        resistor(x, 3.2, 4.6, "1 kΩ bias")
        ax.plot([x], [3.2], "ko", ms=4)
        ax.plot([x, x - 0.6], [3.2, 3.2], color="k")
        ax.text(x - 0.65, 3.2, f"AIN{k}", ha="right", va="center", fontsize=9, color="tab:purple")
        ax.plot([x, x], [3.2, 2.9], color=ELECTRODE_COLOUR, lw=2)
        resistor(x, 1.2, 2.9, f"actuator {k}\n(cTPE, R0 ~ kΩ)", colour="0.2")
        ax.plot([x, x], [1.2, 0.9], color=ELECTRODE_COLOUR, lw=2)
        ax.plot([x, x], [0.9, 0.5], color="k")
    ax.plot([0.6, 7.2], [5.0, 5.0], color="tab:red", lw=2)
    ax.text(7.3, 5.0, "+5 V (also ADS1115 VDD)", va="center", fontsize=9, color="tab:red")
    ax.plot([0.6, 7.2], [0.5, 0.5], color="k", lw=2)
    ax.text(7.3, 0.5, "GND (ADS1115 GND, ADDR)", va="center", fontsize=9)
    ax.text(0.2, 2.05, "copper-wire\nelectrodes", color=ELECTRODE_COLOUR, fontsize=8, ha="center")
    ax.set_xlim(-0.4, 10.5)
    ax.set_ylim(0.2, 5.4)
    ax.set_title("Wiring: one divider per actuator; V = 5 R / (R + 1 kΩ), R = 1 kΩ V / (5 V - V)")
    return _save(fig, path)


def segment_assembly(path=None):
    """3-DoF segment: top view of base, contractors and stage with the BNO055, and a side cut."""
    plt = _plt()
    from matplotlib.patches import Circle as CirclePatch
    from matplotlib.patches import FancyArrow, Rectangle

    fig, (top, side) = plt.subplots(
        1, 2, figsize=(11, 5.2), layout="constrained", gridspec_kw={"width_ratios": [1, 1.15]}
    )
    base, stage = build_part("segment_base").mesh, build_part("segment_stage").mesh
    r_base = base.extents[0] / 2
    r_stage = stage.extents[0] / 2
    top.add_patch(CirclePatch((0, 0), r_base, fc="0.92", ec=PLA_COLOUR, label="base (PLA)"))
    top.add_patch(CirclePatch((0, 0), r_stage, fc="none", ec="k", ls="--", label="stage (PLA), above"))
    plt_cmap, norm = plt.get_cmap(POROSITY_CMAP), _norm()
    corners = D.segment_corners_mm()
    for k, (x, y) in enumerate(corners):
        top.add_patch(CirclePatch((x, y), D.CONTRACTOR_DIAMETER_MM / 2, fc=plt_cmap(norm(D.SEGMENT_POROSITY)), ec="k"))
        top.text(x, y, f"C{k + 1}", ha="center", va="center", color="w", fontsize=10, weight="bold")
        mx, my = (r_stage - 3.0) * np.array([x, y]) / math.hypot(x, y)
        top.plot([mx], [my], "o", color=MARKER_COLOUR, ms=9, mec="k")
    top.plot([0.0], [-(r_base - 3.0)], "s", color=MARKER_COLOUR, ms=9, mec="k", label="marker on the base")
    top.plot([], [], "o", color=MARKER_COLOUR, ms=9, mec="k", label="markers on the stage rim")
    for a, b in zip(corners, corners[1:] + corners[:1]):
        top.plot([a[0], b[0]], [a[1], b[1]], color="k", lw=0.6)
    top.text(0, corners[1][1] - 6, f"{D.SEGMENT_SIDE_MM:g} mm", ha="center", fontsize=8)
    bx, by = 26.7, 20.3
    top.add_patch(Rectangle((-bx / 2, -by / 2), bx, by, fc="#2ca02c", ec="k", alpha=0.8, label="BNO055 (on the stage)"))
    top.add_patch(FancyArrow(0, 0, 11, 0, width=0.6, color="k"))
    top.add_patch(FancyArrow(0, 0, 0, 8, width=0.6, color="k"))
    top.text(12, 0, "x", va="center")
    top.text(0, 9, "y", ha="center")
    top.set_xlim(-r_base - 2, r_base + 2)
    top.set_ylim(-r_base - 2, r_base + 2)
    top.set_aspect("equal")
    top.set_title("top view")
    top.set_xlabel("x (mm)")
    top.set_ylabel("y (mm)")
    top.legend(loc="lower center", fontsize=7, ncol=2, bbox_to_anchor=(0.5, -0.32))
    # Side: cut through the plane x = 0, which holds C1 (at +y).
    h = D.CONTRACTOR_HEIGHT_MM
    floor, z_c = 4.0, 4.0  # contractors stand on the base's cup floors
    _mesh_cut(side, base, normal=(1, 0, 0))
    _mesh_cut(side, stage, normal=(1, 0, 0), transform=_move(z=z_c + h + floor, flip=True))
    y1 = corners[0][1]
    c = D.paper_contractor(D.SEGMENT_POROSITY, port_end="base")
    for r in c.regions:
        for a, b in r.shape.spans(0, 0.0):
            side.add_patch(
                Rectangle(
                    (y1 + a, z_c + r.z0),
                    b - a,
                    r.z1 - r.z0,
                    facecolor=plt_cmap(norm(r.porosity)),
                    edgecolor="white",
                    lw=0.3,
                )
            )
    side.plot([-bx / 2 * 0 - by / 2, by / 2], [z_c + h + floor + 0.4] * 2, color="#2ca02c", lw=4, label="BNO055")
    side.plot(
        [y1, y1],
        [-12, z_c + D.CONTRACTOR_END_MM + 1.0],
        color="k",
        lw=3,
        label="vacuum tubes through the base into the foam",
    )
    side.set_aspect("equal")
    side.autoscale()
    side.set_ylim(-14, z_c + h + 2 * floor + 10)
    side.set_xlabel("y (mm)")
    side.set_ylabel("z (mm)")
    side.set_title("side cut at x = 0 (through C1)")
    side.legend(loc="upper left", fontsize=7)
    _colourbar(fig, side)
    fig.suptitle(f"3-DoF segment: three {D.SEGMENT_POROSITY:g} % contractors on a {D.SEGMENT_SIDE_MM:g} mm triangle")
    return _save(fig, path)


def parts_overview(path=None):
    """3-D views of every fixture mesh, in its print orientation."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from porosense.infoam.parts import PARTS

    plt = _plt()
    fig = plt.figure(figsize=(12, 7.5), layout="constrained")
    light = np.array([0.4, -0.5, 0.8]) / np.linalg.norm([0.4, -0.5, 0.8])
    for k, name in enumerate(PARTS):
        ax = fig.add_subplot(2, 3, k + 1, projection="3d")
        m = build_part(name).mesh
        elev, azim = (-40.0, -60.0) if name == "segment_stage" else (28.0, -60.0)
        e, a = math.radians(elev), math.radians(azim)
        eye = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        front = m.face_normals @ eye > 0  # painter's algorithm: draw only faces turned to the viewer
        lit = eye + 0.3 * light  # a headlight, slightly offset: every visible face is lit
        shade = 0.35 + 0.65 * np.clip(m.face_normals[front] @ (lit / np.linalg.norm(lit)), 0, 1)
        colours = np.column_stack([0.55 * shade, 0.62 * shade, 0.75 * shade, np.ones_like(shade)])
        # Tint flat faces inside the part (cup floors, pockets, ledges) so recesses read.
        zc = m.triangles_center[front][:, 2]
        flat = np.abs(m.face_normals[front][:, 2]) > 0.99
        inner = flat & (zc > m.bounds[0][2] + 1e-3) & (zc < m.bounds[1][2] - 1e-3)
        colours[inner, :3] = np.column_stack([0.95 * shade[inner], 0.6 * shade[inner], 0.25 * shade[inner]])
        ax.add_collection3d(Poly3DCollection(m.triangles[front], facecolors=colours, edgecolors="none"))
        lo, hi = m.bounds
        for set_lim, a0, a1 in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo, hi):
            set_lim(a0, a1)
        ax.set_box_aspect(tuple(np.maximum(m.extents, 0.15 * m.extents.max())))
        ax.view_init(elev=elev, azim=azim)
        x, y, z = m.extents
        note = ", from below: BNO055 pocket" if name == "segment_stage" else ""
        ax.set_title(f"{name}\n{x:.0f} x {y:.0f} x {z:.0f} mm, {m.volume / 1000:.1f} cm³{note}", fontsize=9)
        ax.tick_params(labelsize=6)
    fig.suptitle("PLA fixtures (STL from 'porosense infoam parts'), in print orientation")
    return _save(fig, path, dpi=95)  # thousands of shaded facets: a lower resolution keeps the file small


def _save(fig, path, dpi: int = 120):
    if path is not None:
        save_figure(fig, Path(path), dpi=dpi)
        _plt().close(fig)
    return fig


def write_all(folder) -> list[Path]:
    """Write every figure of docs/assembly.md into ``folder``; returns the paths."""
    from porosense.infoam.design import paper_bending, paper_contractor, paper_segment
    from porosense.infoam.gcode import generate
    from porosense.infoam.preview import plot_toolpath

    folder = Path(folder)
    out = []
    for name, draw in (
        ("assembly_contractor", contractor_assembly),
        ("assembly_bending", bending_assembly),
        ("assembly_wiring", wiring),
        ("assembly_segment", segment_assembly),
        ("assembly_parts", parts_overview),
    ):
        out.append(folder / f"{name}.png")
        draw(out[-1])
    for name, make in (("contractor", paper_contractor), ("bending", paper_bending), ("segment", paper_segment)):
        out.append(folder / f"toolpath_{name}.png")
        plot_toolpath(generate(make()), out[-1])
    return out
