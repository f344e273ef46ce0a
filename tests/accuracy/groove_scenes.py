#!/usr/bin/env python3
"""The scratch scenes of issue 5's accuracy tests and of scripts/bench-grooves: three scratch
layouts (parallel, crossing, ends) on an aluminium test plate seen head-on, each under a ring light
around the lens and under a low-angle bar light across the scratches (dark field). Written as
defectgen configs; `mode` picks how scratches are rendered (groove, geometry, normal_map)."""

LAYOUTS = {
    # Four parallel scratches along u whose ends lie outside the view.
    "parallel": """
  - type: scratch
    count: 4
    orientation_deg: 0
    length_mm: 9
    force_kg: 2
    hardness_hv: 30
    region: [0.46, 0.40, 0.54, 0.60]
""",
    # Two scratches along u crossed by two along v.
    "crossing": """
  - type: scratch
    count: 2
    orientation_deg: 0
    length_mm: 9
    force_kg: 2
    hardness_hv: 30
    region: [0.48, 0.42, 0.52, 0.58]
  - type: scratch
    count: 2
    orientation_deg: 90
    length_mm: 9
    force_kg: 1.5
    hardness_hv: 30
    region: [0.42, 0.48, 0.58, 0.52]
""",
    # Painted (material "paint"): a long scratch through the clear coat and base coat into the
    # primer (force 4 kg, HV 20: 0.069 mm deep under a coat stack of 0.04, 0.015, 0.03 mm),
    # crossed by a short one that ends abruptly at both ends, its end walls cutting every layer.
    "layers": """
  - type: scratch
    count: 1
    orientation_deg: 0
    length_mm: 9
    force_kg: 4
    hardness_hv: 20
    region: [0.49, 0.49, 0.51, 0.51]
  - type: scratch
    count: 1
    orientation_deg: 90
    length_mm: 2
    force_kg: 4
    hardness_hv: 20
    fade_mm: 0
    region: [0.48, 0.48, 0.52, 0.52]
""",
    # Painted (material "paint"): one straight scratch cut by a tool tilted 11 degrees partly
    # forward (azimuth 30), whose pile-up on the light's side has a flank of 48 degrees. Under the
    # bar it mirrors the view down onto the paint beside it at 6.5 degrees, and the orange peel
    # there tilts some of that up into the bar (the fuzzer's c12_17, 2026-11-30).
    "peelside": """
  - type: scratch
    count: 1
    pattern: path
    center: [0.4883, 0.5112]
    path_mm: [-3.2766, 2.2943, 3.2766, -2.2943]
    force_kg: 3.93
    hardness_hv: 60
    perturbation: 0
    tool_tilt_deg: 11
    tool_tilt_azimuth_deg: 30
""",
    # Five short scratches in various directions, ends and fades inside the view.
    "ends": """
  - type: scratch
    count: 5
    length_mm: {uniform: [2, 3.5]}
    orientation_deg: {uniform: [-30, 30]}
    force_kg: 2
    hardness_hv: 30
    fade_mm: 0.6
    region: [0.43, 0.43, 0.57, 0.57]
""",
    # Three parallel scratches side by side (0.17 mm wide with their pile-ups), 0.12 and 0.08 mm
    # apart: their pile-ups overlap, and the outer two cut into the middle one's. Both renderers
    # must build the same composite surface (docs/grooves.md, "Merge").
    "neighbours": """
  - type: scratch
    count: 1
    orientation_deg: 0
    length_mm: 9
    force_kg: 2
    hardness_hv: 30
    center: [0.5, 0.5]
  - type: scratch
    count: 1
    orientation_deg: 0
    length_mm: 9
    force_kg: 2
    hardness_hv: 30
    center: [0.5, 0.506]
  - type: scratch
    count: 1
    orientation_deg: 0
    length_mm: 9
    force_kg: 1.5
    hardness_hv: 30
    center: [0.5, 0.496]
""",
    # Four short scratches (1.6 mm) across the bar light's direction, each within the default
    # force fade (2 mm) from end to end: their depth changes all along them, so their walls slope
    # along the path, and under the bar light that moves their glints (docs/grooves.md, "Renderer",
    # step 4).
    "fades": """
  - type: scratch
    count: 1
    orientation_deg: 37
    length_mm: 1.6
    force_kg: 2.34
    hardness_hv: 60
    center: [0.455, 0.465]
  - type: scratch
    count: 1
    orientation_deg: 45
    length_mm: 1.6
    force_kg: 3
    hardness_hv: 60
    center: [0.545, 0.465]
  - type: scratch
    count: 1
    orientation_deg: 30
    length_mm: 1.6
    force_kg: 1.5
    hardness_hv: 60
    center: [0.455, 0.535]
  - type: scratch
    count: 1
    orientation_deg: 40
    length_mm: 1.6
    force_kg: 4
    hardness_hv: 60
    center: [0.545, 0.535]
""",
    # Six scratches along u crossed by six along v, each set in a 3.2 mm band: crossings whose
    # footprints reach so many pile-ups that the polygons pass their cap of pieces at the full
    # shadow reach (docs/grooves.md, "Cost bound and fallback").
    "dense": """
  - type: scratch
    count: 6
    orientation_deg: 0
    length_mm: 9
    force_kg: 2
    hardness_hv: 30
    region: [0.48, 0.42, 0.52, 0.58]
  - type: scratch
    count: 6
    orientation_deg: 90
    length_mm: 9
    force_kg: 1.5
    hardness_hv: 30
    region: [0.42, 0.48, 0.58, 0.52]
""",
    # Twelve scratches in all directions through a small spot: past the polygons' caps (at most
    # eight grooves per footprint), so the renderer's fallback blend is used there.
    "star": """
  - type: scratch
    count: 12
    length_mm: 4
    orientation_deg: {uniform: [0, 180]}
    force_kg: 1
    hardness_hv: 30
    region: [0.48, 0.48, 0.52, 0.52]
""",
    # Eight deep scratches (20 kg on HV 20: 0.17 mm deep) in all directions through a spot 0.2 mm
    # across, for a view so close (1 degree, 32 pixels: 33 micrometres per pixel) that the polygons'
    # region spans dozens of pixels: most footprints pass the ordinary cap of pieces at every
    # reach, and the close views' cap holds them (docs/grooves.md, "Cost bound and fallback").
    "spot": """
  - type: scratch
    count: 8
    orientation_deg: {uniform: [0, 180]}
    length_mm: 6
    force_kg: 20
    hardness_hv: 20
    region: [0.495, 0.495, 0.505, 0.505]
""",
    # Thirteen scratches in three groups crossing over 1.5 mm, the deepest 0.044 mm (the clusters
    # fuzzer's c58_4, drawn as it drew them; its test looks at one spot of it, look_at).
    "cluster58b": """
  - type: scratch
    count: 4
    orientation_deg: {uniform: [0, 180]}
    length_mm: 8.0
    force_kg: 1.94
    hardness_hv: 20
    region: [0.4585, 0.4905, 0.5100, 0.5420]
    fade_mm: 0.30
    pileup: 0.31
  - type: scratch
    count: 3
    orientation_deg: {uniform: [0, 180]}
    length_mm: 4.3
    force_kg: 1.51
    hardness_hv: 60
    region: [0.4908, 0.4776, 0.5450, 0.5318]
    pileup: 0.12
  - type: scratch
    count: 6
    orientation_deg: {uniform: [0, 180]}
    length_mm: 8.9
    force_kg: 0.33
    hardness_hv: 30
    region: [0.4895, 0.4776, 0.5269, 0.5150]
    curvature_per_mm: {uniform: [0.02, 0.2]}
""",
    # Fourteen scratches in three groups, 0.02 to 0.06 mm deep, crossing and overlapping over a
    # patch 1.4 mm across (the clusters fuzzer's c58_5, drawn as it drew them; its test looks at
    # one spot of it, look_at).
    "cluster58": """
  - type: scratch
    count: 4
    orientation_deg: {uniform: [0, 180]}
    length_mm: 5.3
    force_kg: 1.97
    hardness_hv: 20
    region: [0.4535, 0.4741, 0.5064, 0.5270]
    curvature_per_mm: {uniform: [0.02, 0.2]}
    fade_mm: 0.30
  - type: scratch
    count: 5
    orientation_deg: 153
    length_mm: 6.0
    force_kg: 3.65
    hardness_hv: 30
    region: [0.4491, 0.4740, 0.5132, 0.5382]
    fade_mm: 0.30
  - type: scratch
    count: 5
    orientation_deg: 107
    length_mm: 7.0
    force_kg: 3.31
    hardness_hv: 20
    region: [0.4649, 0.4573, 0.5377, 0.5301]
""",
    # Two scratches given point by point (the corners fuzzer's c60_0, drawn as it drew them; its test
    # looks at one spot of it, look_at): the first, cut by a tool tilted 24 degrees, turns 156
    # degrees at (-0.49, -0.08) mm, and its last leg passes 0.7 micrometres from that vertex; the
    # second's legs cross the cap above it.
    "vertex60": """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.4860, 0.5039]
    path_mm: [0.6263, -4.0743, -0.2075, -0.1622, -0.5099, -1.5973, -1.1121, -0.4334, -1.0822, -0.2228, 2.9086, 0.0477]
    force_kg: 3.30
    hardness_hv: 20
    tool_tilt_deg: 24
    tool_tilt_azimuth_deg: 321
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5000, 0.5124]
    path_mm: [2.9965, 2.2385, -0.2350, -0.1189, -0.6757, 0.0635, -1.1259, 0.0761, 2.5677, -1.4594]
    force_kg: 1.66
    hardness_hv: 20
    perturbation: 0.15
""",
    # Two scratches given point by point and two straight ones across them (the corners fuzzer's
    # c60_2, drawn as it drew them at the default seed; its test sees the fuzzer's whole view):
    # the second path, cut by a tool tilted 11 degrees, turns 145 degrees at (-0.43, 0.10) mm, and
    # a later leg of it runs 1 to 1.2 mm beyond the foot of that corner's pile-up.
    "rise60": """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5058, 0.5170]
    path_mm: [2.1637, 3.2680, 0.1984, -0.2159, 0.0855, -0.1129, 0.5257, -1.3208, 0.6729, -2.4379, 3.0505, 0.7788, 2.3707, -3.1630]
    force_kg: 1.58
    hardness_hv: 20
    perturbation: 0.15
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5053, 0.5024]
    path_mm: [-2.2396, -3.0963, -0.0607, 0.2581, -0.4363, 0.1045, -0.7810, 0.1463, -1.5010, 0.4079, 1.3619, 3.2014, 3.5139, -0.1703]
    force_kg: 2.38
    hardness_hv: 30
    tool_tilt_deg: 11
    tool_tilt_azimuth_deg: 291
  - type: scratch
    count: 2
    orientation_deg: {uniform: [0, 180]}
    length_mm: 4.0
    force_kg: 3.75
    hardness_hv: 30
    region: [0.4905, 0.4905, 0.5095, 0.5095]
""",
    # Two scratches given point by point (the corners fuzzer's c68_4, drawn as it drew them at the
    # default seed; its test sees the fuzzer's whole view): the second crosses the first's tilted
    # groove on a leg that a turn of 148 degrees ends 0.8 mm on, up and to the left, beyond the
    # view, where the rays leaving the first's pile-up nearly along that leg meet only the plate.
    "channel68": """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.4880, 0.5106]
    path_mm: [2.9703, 2.7953, 0.2348, -0.1231, 0.1008, -1.3858, -0.9550, -2.0438, -1.8586, 1.8528]
    force_kg: 2.08
    hardness_hv: 30
    tool_tilt_deg: 29
    tool_tilt_azimuth_deg: 5
    pileup: 0.25
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5141, 0.4990]
    path_mm: [-2.8064, -2.7854, 0.1262, -0.0652, -0.6019, 0.9295, -0.5868, 0.6991, -4.5202, 1.4259]
    force_kg: 1.47
    hardness_hv: 60
""",
    # Two deep scratches side by side whose arcs bend opposite ways (the lines fuzzer's l58_6,
    # drawn as it drew them; its test looks at one spot of it, look_at): the angle between them
    # grows by 3 degrees per mm along them, so in a view 0.5 mm across they are merged as parallel
    # (within 2 degrees) on one side and go to the polygons on the other.
    "nearpar58": """
  - type: scratch
    count: 2
    orientation_deg: 41
    length_mm: 3.9
    force_kg: 3.92
    hardness_hv: 20
    region: [0.4690, 0.4804, 0.4850, 0.4964]
    curvature_per_mm: 0.027
    fade_mm: 0.30
    perturbation: 0.15
  - type: scratch
    count: 2
    orientation_deg: 41
    length_mm: 1.7
    force_kg: 1.80
    hardness_hv: 60
    region: [0.5146, 0.4697, 0.5306, 0.4857]
    curvature_per_mm: 0.111
    fade_mm: 1.00
    perturbation: 0.70
""",
    # Six scratches 1.4 mm long with fades of 0.3 mm crossing near one spot, the view's centre
    # (the clusters fuzzer's c56_1, its first group placed by hand): seen at 1 degree from 15 mm
    # the grooves' fading ends reach the footprints' regions in three pieces each (the integrator's
    # scaleSegments).
    "fades6": """
  - type: scratch
    pattern: path
    center: [0.507808, 0.491236]
    path_mm: [0.5323, -0.4546, -0.5323, 0.4546]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
  - type: scratch
    pattern: path
    center: [0.490614, 0.489240]
    path_mm: [0.6692, -0.2054, -0.6692, 0.2054]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
  - type: scratch
    pattern: path
    center: [0.475012, 0.506199]
    path_mm: [0.5675, -0.4098, -0.5675, 0.4098]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
  - type: scratch
    pattern: path
    center: [0.486870, 0.502764]
    path_mm: [0.6957, -0.0772, -0.6957, 0.0772]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
  - type: scratch
    pattern: path
    center: [0.506725, 0.482049]
    path_mm: [0.1929, -0.6729, -0.1929, 0.6729]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
  - type: scratch
    pattern: path
    center: [0.489073, 0.521644]
    path_mm: [-0.6281, -0.3089, 0.6281, 0.3089]
    force_kg: 3.63
    hardness_hv: 20
    fade_mm: 0.3
""",
    # The clusters fuzzer's c56_1 (seed 56, 2026-12-02): twelve deep scratches in three groups
    # crossing in a cluster about 1 mm across, the short ones with 0.3 mm fades. Seen at 1 degree
    # (44 micrometres per pixel over 24 pixels) a crossing's polygons at the full reach take 8,000
    # to 16,000 pieces.
    "cluster56": """
  - type: scratch
    count: 6
    orientation_deg: {uniform: [0, 180]}
    length_mm: 1.4
    force_kg: 3.63
    hardness_hv: 20
    region: [0.4809, 0.4843, 0.5256, 0.5289]
    fade_mm: 0.30
  - type: scratch
    count: 1
    orientation_deg: {uniform: [0, 180]}
    length_mm: 5.8
    force_kg: 1.38
    hardness_hv: 60
    region: [0.4792, 0.5004, 0.5020, 0.5233]
    curvature_per_mm: {uniform: [0.02, 0.2]}
    fade_mm: 0.00
  - type: scratch
    count: 5
    orientation_deg: {uniform: [0, 180]}
    length_mm: 4.9
    force_kg: 3.06
    hardness_hv: 30
    region: [0.4725, 0.4933, 0.4870, 0.5078]
""",
    # Thirty concentric wash-swirl arcs over most of the view (bench only: the cut mesh has 2.5
    # million triangles, and the time to build it is part of what the bench measures).
    "swirls": """
  - type: scratch
    pattern: swirl
    count: 30
    force_kg: 0.6
    hardness_hv: 30
    fade_mm: 1
    region: [0.2, 0.2, 0.8, 0.8]
""",
}
# Six parallel scratches so deep and wide (about 0.05 and 0.24 mm) and so close (within 0.6 mm)
# that they merge into one band of pile-ups and walls (the fuzzer's c16_18): on glass, light
# refracted into one pile-up's ridge meets the section again from inside.
LAYOUTS["band"] = """
  - type: scratch
    count: 6
    orientation_deg: 41
    length_mm: 5.7
    force_kg: 2.31
    hardness_hv: 20
    region: [0.4779, 0.4763, 0.5087, 0.5071]
"""
# The band crossed by two scratches as deep: on glass, light refracted into the pile-ups and walls
# where they cross meets the polygon surface again from inside.
LAYOUTS["crossed_band"] = LAYOUTS["band"] + LAYOUTS["band"].replace("count: 6", "count: 2").replace(
    "orientation_deg: 41", "orientation_deg: 131")
# The fuzzer's c18_6: six light scratches in random directions, three deep curved ones (3.9 kg on
# HV 20) whose force fades out over 0.3 mm among them, and one more deep one. Around a deep
# groove's faded tip the polygons' linear scale (the tangent at the closest point) stood its
# pile-up up to three times its height, shadowing and cutting the light grooves' lit walls.
LAYOUTS["tips"] = """
  - type: scratch
    count: 6
    orientation_deg: {uniform: [0, 180]}
    length_mm: 6.2
    force_kg: 0.63
    hardness_hv: 30
    region: [0.4831, 0.4240, 0.5764, 0.5173]
    fade_mm: 0.30
    pileup: 0.14
  - type: scratch
    count: 3
    orientation_deg: 119
    length_mm: 2.3
    force_kg: 3.91
    hardness_hv: 20
    region: [0.4778, 0.4433, 0.5624, 0.5279]
    curvature_per_mm: {uniform: [0.02, 0.2]}
    fade_mm: 0.30
  - type: scratch
    count: 1
    orientation_deg: {uniform: [0, 180]}
    length_mm: 5.1
    force_kg: 3.71
    hardness_hv: 20
    region: [0.4366, 0.4751, 0.5299, 0.5683]
"""
# The ends layout's five scratches with blunt ends (no fade): each groove stops at full depth at its
# end line.
LAYOUTS["blunt"] = LAYOUTS["ends"].replace("fade_mm: 0.6", "fade_mm: 0")
# One scratch given point by point (pattern: path) that turns four corners in view, by 90 degrees
# to the left, 105 and 120 to the right and 135 to the left, its legs 0.9 to 1.1 mm long: each
# corner round on its outer side and creased along its bisector on the inner one, two of them
# within a shadow reach of each other (docs/grooves.md, "Corners"). Seen at 3 degrees.
LAYOUTS["zigzag"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-4, -0.4, -0.6, -0.4, -0.6, 0.5, 0.5, 0.2, -0.2, -0.5, 4, -0.5]
    force_kg: 2
    hardness_hv: 30
"""

# A scratch given point by point that doubles back: a polyline turning 179 degrees, its two 3 mm
# legs side by side, 0.017 mm apart per mm from the vertex, so that their 0.19 mm wide grooves
# overlap over the whole view (seen at 1.5 degrees, the vertex 0.6 mm right of the centre). Each
# point takes the cross-section of the nearer leg; within 2 mm of the path's ends (the default
# fade) the force, and so the scale, changes along each leg (docs/grooves.md, "A path that comes
# back").
LAYOUTS["doubling"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-2.4, -0.05, 0.6, -0.05, -2.399543, 0.002357]
    force_kg: 2
    hardness_hv: 30
"""

# A scratch given point by point that goes exactly back over itself: a polyline out 3 mm and back
# along the same line, its vertex 0.6 mm right of the centre (seen at 1.5 degrees). The explicit
# geometry gives each point the earlier pass's cross-section (a tie, broken to the lower segment)
# and a round cap beyond the vertex; the force's perturbation along the path makes the two passes'
# cross-sections differ where they lie on each other (docs/grooves.md, "A path that comes back").
LAYOUTS["retrace"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-2.4, -0.05, 0.6, -0.05, -2.4, -0.05]
    force_kg: 2
    hardness_hv: 30
"""

# A scratch given point by point that goes back along itself for 0.1 mm and then turns 90 degrees
# away: two corners 0.1 mm apart on a groove 0.19 mm wide, the first a half turn (seen at 1.5
# degrees; docs/grooves.md, "Straight back over itself").
LAYOUTS["turnback"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-3, 0, 0.3, 0, 0.2, 0, 0.2, 3]
    force_kg: 2
    hardness_hv: 30
"""

# A cubic followed by its own reverse, cut by a tool tilted 7 degrees (seen at 1.5 degrees): the
# path goes out 6 mm and comes back over the same flattened points, its tip 0.25 mm up-right of the
# centre (the retraces fuzzer's r2_4, moved; 2.83 kg with a high pile-up and a strong perturbation). The explicit geometry keeps the way out's cross-section, whose two sides differ, and a
# round cap beyond the tip; the polygons must take the way out's bends for both passes, so that
# their legs lie on one line (ScratchPath::bendsAround; docs/grooves.md, "Straight back over
# itself").
LAYOUTS["recurve"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.5, 0.5]
    path_mm: [0.3459, -5.6308, -0.9195, -0.0715, 2.9053, -2.5842, 0.238, 0.1576, 2.9053, -2.5842, -0.9195, -0.0715, 0.3459, -5.6308]
    force_kg: 2.83
    hardness_hv: 30
    perturbation: 0.4
    pileup: 0.83
    tool_tilt_deg: 7
    tool_tilt_azimuth_deg: 302
"""

# A light scratch given point by point that comes back along its own line and ends short of its
# start (the retraces fuzzer's r4_19, its end put exactly on the line): out 5.3 mm to 0.35 mm right
# of the centre and back 0.95 mm to 0.6 mm left of it (seen at 1.5 degrees), the force fading over
# the path's last 2 mm, the whole way back. The explicit geometry keeps the way out's
# cross-section wherever the two lie on each other, and past the end of the way back the way out
# is the nearer (docs/grooves.md, "Straight back over itself").
LAYOUTS["shortback"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-4.9657, -0.3683, 0.3492, -0.1024, -0.6043, -0.15010280720239327]
    force_kg: 0.4
    hardness_hv: 20
    perturbation: 0
    pileup: 0.88
"""

# The same path as the retraces fuzzer drew it, its coordinates rounded to four decimals: the way
# back ends 3 nm off the way out's line, 3e-6 rad (seen at 1.5 degrees). Put on that line when
# the path is built (ScratchPath::polyline, docs/grooves.md, "Nearly one line"), it is the
# shortback layout to within 3 nm.
LAYOUTS["nearline"] = LAYOUTS["shortback"].replace("-0.15010280720239327]", "-0.1501]")
assert LAYOUTS["nearline"] != LAYOUTS["shortback"]

# The retraces fuzzer's r2_4 cut short: a chord out and exactly back, by a tool tilted 7 degrees
# (2.83 kg on HV 30: 0.044 mm deep), its half turn at the view's centre, to be seen from very close
# (a third of a millimetre across). There the polygons' square region is small against the groove,
# and the steep walls of the cap beyond the vertex send much of their light down the groove, out of
# the region (docs/grooves.md, "A half turn's step, seen very close").
LAYOUTS["halftip"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [2.6753, -2.7562, 0.0080, -0.0144, 2.6753, -2.7562]
    force_kg: 2.83
    hardness_hv: 30
    perturbation: 0
    tool_tilt_deg: 7
    tool_tilt_azimuth_deg: 302
    pileup: 0.83
"""

# A scratch given point by point that goes back and forth: three 10 mm legs 0.1 mm apart at the
# centre (the middle one tilted by 0.57 degrees), turning by about 179.4 degrees 5 mm either side,
# out of view (seen at 1.5 degrees). Their 0.19 mm wide grooves overlap; each point takes the
# nearest leg's cross-section (docs/grooves.md, "A path that comes back").
LAYOUTS["backforth"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-5, 0.1, 5, 0.1, -5, 0, 5, -0.1]
    force_kg: 2
    hardness_hv: 30
"""

# The passes fuzzer's p3_18 (`scripts/fuzz-grooves --kind passes --seed 3`, layout 18): a cubic
# hairpin whose tip 0.2 mm across flattens into eight corners of 12 to 17 degrees, beside a light
# scratch, seen at 1 degree (docs/grooves.md, "Bends").
LAYOUTS["tipcorners"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.4979, 0.5124]
    path_mm: [3.1362, -6.5670, -2.9804, 8.6298, -0.6126, -9.3468, 1.3603, 6.9155]
    force_kg: 0.56
    hardness_hv: 30
    perturbation: 0.40
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.5099, 0.5037]
    path_mm: [-2.9265, 4.0712, 0.1844, -0.3918, 0.3068, -0.5674, 0.2190, -0.6286, 0.1312, -0.6898, 0.0089, -0.5142, -3.1021, 3.9489]
    force_kg: 0.84
    hardness_hv: 30
"""

# A scratch whose path comes back across itself (docs/grooves.md, "A path that comes back"): one
# cubic curve that loops, crossing its own way at 78 degrees 0.27 mm below the loop's top, where
# the two passes' grooves overlap (seen at 3 degrees).
LAYOUTS["loop"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.5, 0.5]
    path_mm: [-9, -3.65, 12, 1.75, -12, 1.75, 9, -3.65]
    force_kg: 2
    hardness_hv: 30
"""

# A path that turns back beside itself (seen at 3 degrees; the turn, 6 mm away, out of view): its
# two legs 0.12 mm apart, their grooves (0.18 mm wide with their pile-ups) overlapping, each holding on its side of
# the midline as the nearer pass.
LAYOUTS["hairpin"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-4, 0.06, 6, 0.06, 6, -0.06, -4, -0.06]
    force_kg: 2
    hardness_hv: 30
"""

# A path that turns three corners within a groove's width or two (seen at 2 degrees): along y =
# -0.12 mm, back up-left to (0.05, 0.05), out to (0.2, 0.12) and back along y = 0.1 over the first
# leg's pile-up. The polygons take the corners together (docs/grooves.md, "Corners close
# together"): a leg no longer stops at the next corner inside the groove.
LAYOUTS["knot"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-4, -0.12, 0.15, -0.12, 0.05, 0.05, 0.2, 0.12, -4, 0.1]
    force_kg: 2
    hardness_hv: 30
"""

# A cubic that curls into a loop about 0.3 mm across and crosses its own way (seen at 2 degrees):
# its flattened vertices turn by 2 to 40 degrees each, corners and not. The polygons follow its
# bends (ScratchPath::bendsAround; docs/grooves.md, "Bends"), where its corners' straight legs or
# its tangent stood for it before.
LAYOUTS["curl"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.5, 0.5]
    path_mm: [-2.6223, 2.5, 2.7241, -4.7441, -1.0104, 4.4945, 0.1786, -4.4296]
    force_kg: 2
    hardness_hv: 30
"""

# A path that crosses its own earlier leg next to a corner (seen at 2 degrees): down along x = -0.1
# mm, back up beside it, 0.15 mm apart at the top (the turn 4 mm away, out of view), then a corner
# of 110 degrees to the left whose outgoing leg crosses the first leg 0.16 mm from the vertex. The
# corner's legs and the first leg are runs of one partition, each holding where it is the nearer
# (docs/grooves.md, "A path that comes back"), as in the corner fuzzer's c5_8.
LAYOUTS["hook"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5, 0.5]
    path_mm: [-0.1, 4, -0.1, -4, 0.05, 0.1, -4, -1.2]
    force_kg: 2
    hardness_hv: 30
"""

# A polyline cut by a tool tilted 21 degrees that turns back by 162 degrees 0.2 mm after its first
# vertex, crossed by two straight scratches through a spot 0.5 mm across (the corner fuzzer's
# c41_7 at its seed), for a view at 1 degree, 48 pixels: 22 micrometres per pixel. The deep straight
# grooves (0.033 mm) reach 0.25 mm toward the low bar, 23 pixel radii: near the turn the polygons'
# region at the full reach holds more pieces than the ordinary cap (docs/grooves.md, "Close views").
LAYOUTS["tiltpin"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: polyline
    center: [0.5075, 0.4916]
    path_mm: [-3.7423, 1.2709, 0.0406, -0.0287, 0.1999, 0.0855, -0.5551, -0.9110, -0.0896, -1.5433, 0.7351, 2.3708]
    force_kg: 0.98
    hardness_hv: 60
    tool_tilt_deg: 21
    tool_tilt_azimuth_deg: 356
  - type: scratch
    count: 2
    orientation_deg: {uniform: [0, 180]}
    length_mm: 6.9
    force_kg: 1.21
    hardness_hv: 20
    region: [0.4882, 0.4882, 0.5118, 0.5118]
"""

# A cubic that loops tightly across its own way (about 0.5 mm across, two of its flattened vertices
# turning by 10 degrees or more: corners), for a view at 1 degree, 48 pixels (the passes fuzzer's
# p45_3 at its seed). Near the loop the later pass lies outside the earlier one's window of bends,
# and until the forty-fifth session both stood their corners' straight legs there: a leg ran
# across the loop (docs/grooves.md, "Bends").
LAYOUTS["tightloop"] = """
  - type: scratch
    count: 1
    pattern: path
    curve: bezier
    center: [0.4957, 0.5008]
    path_mm: [-2.8962, -2.8815, 4.3620, 3.3015, -5.1229, -1.3258, 4.2175, 0.5890]
    force_kg: 2.92
    hardness_hv: 60
    pileup: 0.96
"""

# Three groups of scratches crossing near the view's centre: five at 34 degrees, six at 150 and six
# at random angles, 17 in all, for a view at 2 degrees, 48 pixels (the clusters fuzzer's c52_5 at its
# seed). Beside the crossings a footprint's region holds more than 16 grooves at the full and the half
# reach when the curved ones are cut into pieces along their paths, but not at the half reach with
# each whole; the centre is past the caps at every reach (trimmed footprints).
LAYOUTS["groups"] = """
  - type: scratch
    count: 5
    orientation_deg: 34
    length_mm: 3.2
    force_kg: 1.89
    hardness_hv: 20
    region: [0.4830, 0.4699, 0.4999, 0.4868]
    curvature_per_mm: {uniform: [0.02, 0.2]}
  - type: scratch
    count: 6
    orientation_deg: 150
    length_mm: 4.8
    force_kg: 2.91
    hardness_hv: 20
    region: [0.5218, 0.4714, 0.5341, 0.4836]
    curvature_per_mm: {uniform: [0.02, 0.2]}
    fade_mm: 0.00
    pileup: 0.12
  - type: scratch
    count: 6
    orientation_deg: {uniform: [0, 180]}
    length_mm: 4.8
    force_kg: 3.64
    hardness_hv: 30
    region: [0.5185, 0.4813, 0.5354, 0.4983]
"""

LIGHTS = {
    # Bright field through a glass part: a 12 x 12 mm panel 50 mm below the plate, facing up, which
    # the flat glass shows whole; a groove's facets refract the view off it.
    "backlight": """
  - type: rect
    position: [0, 0, -50]
    target: [0, 0, 0]
    size_mm: [12, 12]
    radiance: [0.8, 0.8, 0.8]
  - type: dome
    radiance: [0.04, 0.04, 0.04]
""",
    "ring": """
  - type: ring
    radius_mm: 30
    inner_radius_mm: 20
    radiance: [6, 6, 6]
  - type: dome
    radiance: [0.04, 0.04, 0.04]
""",
    # Across the u scratches: light from +v at 12 degrees elevation.
    "bar": """
  - type: bar
    length_mm: 300
    width_mm: 20
    distance_mm: 200
    elevation_deg: 12
    azimuth_deg: 90
    radiance: [25, 25, 25]
  - type: dome
    radiance: [0.04, 0.04, 0.04]
""",
    # An even sky alone: all the light a groove's walls pass on reaches them over bounces, which a
    # close view of steep walls makes most of the image.
    "dome": """
  - type: dome
    radiance: [0.5, 0.5, 0.5]
""",
}

PARTS = {
    "plate": "{type: plate, width_mm: 20, height_mm: 20}",
    # A door skin (100 x 100 mm, bowed across its height with radius 200 mm, 10 mm triangles),
    # seen where its normal leans 8.6 degrees from the view axis of the flat scenes: 30 mm above the
    # bow's crest. The explicit geometry there cuts the part's curved triangles and follows the
    # interpolated normal, as the groove renderer's frames do.
    "bowed": "{type: door_panel, width_mm: 100, height_mm: 100, curvature_radius_mm: 200, "
             "character_line_depth_mm: 0}",
}

# The bowed part's spot: y = 30 mm (arc length 80.65 of 101.07 mm from the bottom edge); the mesh is
# centred on its bounding box, so the surface is at z = sqrt(200^2 - 30^2) - 200 + 3.1754 there.
_BOW_R, _BOW_Y = 200.0, 30.0


def _bowed_regions(layout_text):
    """The layout's regions (fractions of the 20 mm plate) moved to the same millimetres around the
    bowed part's spot."""
    import math
    import re
    s_total = 2 * _BOW_R * math.asin(50 / _BOW_R)
    v0 = (_BOW_R * (math.asin(_BOW_Y / _BOW_R) + math.asin(50 / _BOW_R))) / s_total

    def move(m):
        a, b, c, d = (float(x) for x in m.group(1).split(","))
        u = lambda f: 0.5 + (20 * f - 10) / 100
        v = lambda f: v0 + (20 * f - 10) / s_total
        return "region: [%.5f, %.5f, %.5f, %.5f]" % (u(a), v(b), u(c), v(d))
    return re.sub(r"region: \[([^\]]*)\]", move, layout_text)


def _camera(part, fov_deg, distance_mm=60, look_at=(0, 0)):
    if part == "plate":
        x, y = look_at
        return "{fov_deg: %g, position: [%g, %g, %g], target: [%g, %g, 0]}" % (fov_deg, x, y, distance_mm, x, y)
    import math
    ny = _BOW_Y / _BOW_R
    nz = math.sqrt(1 - ny * ny)
    z = math.sqrt(_BOW_R ** 2 - _BOW_Y ** 2) - _BOW_R + (_BOW_R - math.sqrt(_BOW_R ** 2 - 50 ** 2)) / 2
    return "{fov_deg: %g, position: [0, %.4f, %.4f], target: [0, %.4f, %.4f]}" % (
        fov_deg, _BOW_Y + 60 * ny, z + 60 * nz, _BOW_Y, z)

SCENES = [(layout, light) for layout in ("parallel", "crossing", "ends") for light in ("ring", "bar")]


MATERIALS = {
    "aluminium": "{type: metal, metal: aluminium, roughness: %g}",
    # A polycarbonate lamp lens, 3 mm thick, polished.
    "glass": "{type: glass, ior: 1.59, roughness: 0.02, thickness_mm: 3}",
    # Red car paint over the default coat stack: a scratch through the clear coat shows the base
    # coat, then the grey primer.
    "paint": "{type: car_paint, base_color: [0.5, 0.04, 0.03], flake_amount: 0, flake_density: 0, sparkle: 0, "
             "clear_coat_roughness: 0.05}",
}
# The same paint with resolved metallic flakes (0.03 mm, in cells of 0.06 mm: at the accuracy
# scenes' 3-degree view, 33 um per pixel, each one sparkles on its own, on the grooves' walls too).
MATERIALS["flakes"] = MATERIALS["paint"].replace("flake_amount: 0, flake_density: 0, sparkle: 0",
                                                 "flake_amount: 0.3, flake_density: 0.8, sparkle: 1")
# The same flakes lying flat in the coat (no tilt): on every facet each one mirrors that facet, so
# the light a groove passes from wall to wall over two flakes is as sharp as can be.
MATERIALS["flat_flakes"] = MATERIALS["flakes"].replace("sparkle: 1", "sparkle: 1, flake_tilt_deg: 0")


def config(layout, light, mode, spp, resolution=96, seed=11, noise_seed=0, roughness=0.15, fov_deg=5, part="plate",
           material="aluminium", png16=False, scratched=True, count=None, distance_mm=60, cell_mm=None, max_bounces=4,
           look_at=(0, 0)):
    """noise_seed: 0 for the renders under test; references use another value so that their noise
    is independent of theirs (the same seed would give geometry at N spp the first N samples of the
    reference's). roughness: the aluminium's. png16: 16-bit PNGs, so that a comparison is not
    limited by 8-bit rounding (scripts/bench-grooves). scratched: False leaves the scratches out (the
    bare plate under the same lights and camera, which scripts/bench-grooves times). count: the
    number of scratches of a one-group layout (scripts/bench-grooves --density), else the layout's.
    distance_mm: the camera's height over the plate (plate only; the field of view is at least 1 degree: 20 mm
    sees a third of a millimetre across). cell_mm: the explicit geometry's finest cells
    (render.geometry_cell_mm; other modes leave it out), for views so close that the automatic cell
    spans pixels. max_bounces: the path length in bounces (1: direct light only, which shows the
    surfaces' shapes and shadows without the light between walls). look_at: the point of the plate
    (mm) that the camera looks straight down at, so that a spot of a fuzzer's layout can be seen
    close with its draws unchanged (plate only)."""
    text = LAYOUTS[layout]
    if count is not None:
        import re
        if len(re.findall(r"count: \d+", text)) != 1:
            raise ValueError("count= needs a layout with one group of scratches, not %r" % layout)
        text = re.sub(r"count: \d+", "count: %d" % count, text)
    mat = MATERIALS[material] % roughness if material == "aluminium" else MATERIALS[material]
    return """# generated by tests/accuracy/groove_scenes.py: %s scratches under the %s light
seed: %d
count: 1
part: %s
material: %s
lights:%s
camera: %s
render: {resolution: [%d, %d], spp: %d, max_bounces: %d, scratches: %s, noise_seed: %d%s}
defects:%s""" % (layout, light, seed, PARTS[part], mat, LIGHTS[light], _camera(part, fov_deg, distance_mm, look_at), resolution, resolution, spp,
                 max_bounces,
                 mode, noise_seed, (", png: 16" if png16 else "") +
                 (", geometry_cell_mm: %g" % cell_mm if cell_mm and mode == "geometry" else ""),
                 " []\n" if not scratched else text if part == "plate" else _bowed_regions(text))


# The example (configs/scratched_door.yaml) with its random draws fixed: a painted door
# panel, 1000 x 600 mm, with twelve wash swirls and two key scratches through the clear coat, under
# the dark-field bar light at about the angles the example's first sample drew; seen 46 mm wide (0.48
# mm per pixel at 96 pixels: the swirls' grooves, 0.16 mm wide, are a third of a pixel, as an
# inspection camera sees a door). Bench only (scripts/bench-grooves --door): the explicit geometry
# cuts every scratch on the door, 21 million triangles, 32 s to build on 2 cores and 6.4 GB.
DOOR = """# generated by tests/accuracy/groove_scenes.py: the scratched door (configs/scratched_door.yaml)
seed: 5
count: 1
part: {type: door_panel, width_mm: 1000, height_mm: 600, curvature_radius_mm: 1500, character_line_height: 0.62}
material: {type: car_paint, base_color: [0.02, 0.03, 0.08], flake_amount: 0.2, clear_coat_roughness: 0.03}
lights:
  - {type: bar, length_mm: 900, width_mm: 40, distance_mm: 600, elevation_deg: 12, azimuth_deg: 66, radiance: [60, 60, 60]}
  - {type: dome, radiance: [0.04, 0.04, 0.045]}
camera: {fov_deg: 6, position: [-27, -109, 420], target: [-14, 11, 0], up: [0, 1, 0]}
render: {resolution: [%d, %d], spp: %d, max_bounces: 3, scratches: %s, noise_seed: %d%s}
defects:%s"""

DOOR_SCRATCHES = """
  - {type: scratch, pattern: swirl, count: 12, force_kg: 0.6, hardness_hv: 15, tool_apex_deg: 110, fade_mm: 8,
     region: [0.46, 0.44, 0.54, 0.56]}
  - {type: scratch, pattern: key, count: 2, force_kg: 4, hardness_hv: 20, tool_apex_deg: 90, fade_mm: 15,
     region: [0.45, 0.45, 0.55, 0.55]}
"""


def door_config(mode, spp, resolution=96, noise_seed=0, png16=False, scratched=True):
    """The scratched door (DOOR); arguments as config's."""
    return DOOR % (resolution, resolution, spp, mode, noise_seed, ", png: 16" if png16 else "",
                   DOOR_SCRATCHES if scratched else " []\n")


if __name__ == "__main__":
    import sys
    print(config(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), part=sys.argv[5] if len(sys.argv) > 5 else "plate"))
