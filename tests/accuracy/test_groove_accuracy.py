#!/usr/bin/env python3
"""Issue 5 accuracy: the groove renderer at 4 samples per pixel against the explicit-geometry
reference (the same scratches cut into the re-meshed part, rendered by the same path tracer at
REF_SPP samples per pixel), on three scratch layouts under a ring light and a low-angle bar light,
the crossing layout on a curved part under both, a layered car paint under both, and a glass lens
(four layouts, one of them also bowed: six scenes) under a back light or the ring, measured with `defectgen
compare` (S-CIELAB, Delta E 1976, 40 samples per degree).

Target (Bosch 2007 reports 0.32% and 0%): fewer than 0.5% of pixels with Delta E >= 10, and a mean
Delta E below 1, asserted on every case. Each case prints its mean Delta E and share >= 10. The
reference renders with another noise seed (render.noise_seed), so its noise is independent of the
renders it is compared with. Renders are deterministic, so the figures are the same on every run."""

import argparse
import json
import os
import shutil
import subprocess
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import groove_scenes  # noqa: E402

ARGS = None
REF_SPP = 1024
TARGET_PCT = 0.5
TARGET_MEAN = 1.0


def run(*args):
    p = subprocess.run([ARGS.binary] + list(args), capture_output=True, text=True, timeout=900)
    if p.returncode != 0:
        raise AssertionError("defectgen %s failed (%d):\n%s%s" % (" ".join(args), p.returncode, p.stdout, p.stderr))
    return p


def render(name, layout, light, mode, spp, noise_seed=0, part="plate", **scene):
    d = os.path.join(ARGS.work, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    cfg = os.path.join(d, "scene.yaml")
    with open(cfg, "w") as f:
        f.write(groove_scenes.config(layout, light, mode, spp, noise_seed=noise_seed, part=part, **scene))
    run("generate", cfg, "--out", os.path.join(d, "out"), "--quiet")
    return os.path.join(d, "out", "images", "000000.png")


def footprints(name):
    """How the groove render `name` integrated its footprints: sections, polygons, fallbacks."""
    with open(os.path.join(ARGS.work, name, "out", "manifest.json")) as f:
        return json.load(f)["last_run"]["timings"]["samples"][0]["groove_footprints"]


def compare(ref, test, name):
    out = os.path.join(ARGS.work, name + "_cmp")
    shutil.rmtree(out, ignore_errors=True)
    run("compare", ref, test, "--out", out, "--samples-per-degree", "40")
    with open(os.path.join(out, "report.json")) as f:
        return json.load(f)["stats"]["valid"]


class GrooveAccuracy(unittest.TestCase):
    def check(self, layout, light, part="plate", max_pct=TARGET_PCT, max_mean=TARGET_MEAN, name=None, past_caps=False,
              spp=4, ref_spp=REF_SPP, **scene):
        """Renders the layout both ways and compares them. max_pct and max_mean: the bounds, the
        issue's target unless a scene is known to need wider ones, or is held to tighter ones (its
        test says why). name: the work folders' name, where layout, light and part do not tell it.
        past_caps: the layout has footprints past the polygons' caps at every reach (trimmed), and
        must have them; else it must have none. spp and ref_spp: the groove render's and the
        geometry reference's samples per pixel."""
        tag = name or "%s_%s%s" % (layout, light, "" if part == "plate" else "_" + part)
        ref = render(tag + "_ref", layout, light, "geometry", ref_spp, noise_seed=1, part=part, **scene)
        grv = render(tag + "_groove", layout, light, "groove", spp, part=part, **scene)
        st = compare(ref, grv, tag)
        pct, mean = st["pct_ge_10"], st["mean"]
        bound = "target" if (max_pct, max_mean) == (TARGET_PCT, TARGET_MEAN) else "bound"
        print("%-9s %-5s %-5s groove@%dspp vs geometry@%dspp: mean dE %.3f, %.3f%% of pixels >= 10 (%s < %.2f%%, mean < %.2f)"
              % (layout, light, part, spp, ref_spp, mean, pct, bound, max_pct, max_mean), flush=True)
        self.assertLess(pct, max_pct)
        self.assertLess(mean, max_mean)
        # No footprint of these scenes is past the polygons' caps. The ends' tips, where the force
        # fade leaves no cross-section at the closest point, are polygons too (until 2026-11-28
        # they went to the blend: 109 footprints on each ends scene).
        used = footprints(tag + "_groove")
        if past_caps:
            self.assertGreater(used["trimmed"], 0)
            self.assertEqual(used["fallbacks"], 0)
        else:
            self.assertEqual((used["trimmed"], used["fallbacks"]), (0, 0))
        return st

    def test_crossing_ring_bowed(self):
        """The crossing layout on a curved part (groove_scenes.PARTS["bowed"]): the reference cuts
        the part's curved triangles, and both follow the interpolated normal."""
        self.check("crossing", "ring", "bowed")

    def test_crossing_bar_bowed(self):
        self.check("crossing", "bar", "bowed")

    def test_layers_ring(self):
        """Car paint (groove_scenes.LAYOUTS["layers"]): a scratch through the clear coat and base
        coat shows the primer, in the groove renderer's facets and in the reference's cut mesh
        (each hit takes the layer at its depth). Seen closer (field of view 2 degrees) so that the
        grooves are several pixels wide. Against a reference that showed the top coat everywhere,
        this gave 4.3% of pixels >= 10."""
        self.check("layers", "ring", material="paint", fov_deg=2)

    def test_layers_bar(self):
        """The same under the bar light: the walls' highlights are the clear coat's sharp lobe,
        which the reference must not tilt with the uncut coat's orange peel (with it: 1.4% of
        pixels >= 10)."""
        self.check("layers", "bar", material="paint", fov_deg=2)

    def test_peelside_bar(self):
        """Car paint, one straight scratch cut by a tilted tool (groove_scenes.LAYOUTS["peelside"]):
        its pile-up's outer flank mirrors the view onto the uncut paint beside it, whose orange peel
        tilts part of it into the bar. Before the groove renderer's flat facets took the peel:
        1.36% of pixels >= 10 (mean 0.63)."""
        self.check("peelside", "bar", material="paint", fov_deg=3)

    def test_peelside_flakes_bar(self):
        """The same scratch in car paint with resolved metallic flakes (groove_scenes.MATERIALS
        ["flakes"]): each sparkles where its normal mirrors the bar into the view, on the plate and
        on the groove's walls, whose flakes lie in the clear coat's top layer. A flake's normal is
        given in the frame of the surface's normal and dpdu; on a wall the explicit geometry's dpdu
        comes from the part's UVs at the points below, and the groove renderer carries the plate's
        dpdu onto the facet the same way (groove::facetTangent). Projected orthogonally instead
        (before the forty-fourth session), the walls' flakes were turned about their normals
        wherever the scratch runs oblique to u (here 35 degrees): 0.36% of pixels >= 10, mean
        0.70, against 0.03% and 0.61 now. Held to 0.15% and 0.65, so that the old frames fail."""
        self.check("peelside", "bar", material="flakes", fov_deg=3, max_pct=0.15, max_mean=0.65,
                   name="peelside_flakes_bar")

    def test_peelside_flat_flakes_ring_close(self):
        """The peelside scratch in car paint whose resolved flakes lie flat in the coat
        (groove_scenes.MATERIALS["flat_flakes"]), seen from close (1 degree, 22 um per pixel,
        flakes of 30 um) under the ring: each flake on a wall mirrors that wall. The light a
        footprint's bounced directions meet lies elsewhere on the surface, not under the flake its
        camera hit drew; until the fifty-first session every facet in the groove took that flake,
        so a sparkling footprint mirrored the ring off the opposite wall through the same flake
        (mean dE 1.47, 0.35% of pixels >= 10; now 0.65 and 0%). 48 x 48 pixels, 16-bit, the
        groove renderer at 16 spp against geometry at 512, as the fuzzer's close views with flakes
        (docs/grooves.md, "Flakes beyond the camera hit")."""
        self.check("peelside", "ring", material="flat_flakes", fov_deg=1, resolution=48, png16=True, spp=16,
                   ref_spp=512, max_pct=0.15, max_mean=0.9, name="peelside_flat_flakes")

    def test_glass_parallel_backlight(self):
        """A polycarbonate lens (groove_scenes.MATERIALS["glass"], a 3 mm solid) over a back light
        (bright field): the flat glass shows the light, a groove's facets refract the view off it
        (Bosch §4.3, E_t). The groove renderer sends each portion's refracted share through the
        solid as ordinary rays; the reference refracts at its cut facets."""
        self.check("parallel", "backlight", material="glass")

    def test_glass_crossing_backlight(self):
        """The same through crossings (polygons, walls included)."""
        self.check("crossing", "backlight", material="glass")

    def test_glass_crossing_backlight_bowed(self):
        """The lens bowed (groove_scenes.PARTS["bowed"], its back made from the curved surface):
        seen through the tilted glass the panel is out of view (dark field), and the scratches'
        facets refract it into view."""
        self.check("crossing", "backlight", "bowed", material="glass")

    def test_glass_ends_ring(self):
        """Scratch ends on the lens under the ring light: what the grooves reflect of the ring over
        the dark glass, and what they refract of the dome below."""
        self.check("ends", "ring", material="glass")

    def test_glass_band_backlight(self):
        """Six deep parallel scratches merged into one band (groove_scenes.LAYOUTS["band"]) on the
        lens over the back light: light refracted into one pile-up's ridge meets the section again
        from inside, and leaves through the ridge's far side or a groove's wall. Until 2026-11-28
        every refracted ray went straight on into the solid, and the band's core lacked 5% of its
        light: 1.55% of pixels >= 10 (mean dE 0.57); now 0.17% (0.33)."""
        self.check("band", "backlight", material="glass")

    def test_glass_crossed_band_backlight(self):
        """The band crossed by two scratches as deep (groove_scenes.LAYOUTS["crossed_band"]): where
        they cross the footprints are polygons, and light refracted into a pile-up there meets the
        pieces again from inside (Surface::scatterInside). Until 2026-11-28 such rays went straight
        on into the solid, and the crossings lacked 1.5 to 3% of their light: 0.499% of pixels
        >= 10 (mean dE 0.42); now 0.076% (0.33). Bounded at half the target, which the old
        renderer fails."""
        st = self.check("crossed_band", "backlight", material="glass")
        self.assertLess(st["pct_ge_10"], 0.25)
        self.assertGreater(footprints("crossed_band_backlight_groove")["polygons"], 0)

    def test_glass_cluster_inside_ring(self):
        """Fourteen crossing scratches on the lens under the ring light (groove_scenes.LAYOUTS
        ["cluster58"], the clusters fuzzer's c58_5), one spot of it seen at 1 degree from 60 mm
        (44 micrometres per pixel), 24 x 24 pixels. Light that enters through one groove's wall,
        meets the back face and comes up again leaves through the scratched face where the
        grooves overlap; there the groove renderer point-samples the scratches. Until the
        fifty-third session it added their slopes, so where two overlapped the normal took both
        walls' tilts, and the glints that the reference's composite surface sends out were
        missing: 5.2% of pixels >= 10 (mean dE 2.40; at 8 spp against 512, 4.5%, and 0% with
        max_bounces 2, which stops before the light comes up again). Now the point samples take
        the slope of the groove that holds the composite surface (DefectShading::addGroove), as
        the explicit geometry cuts it: 0% (1.09; 0.92 at 8 spp). Since the sixty-first session
        the point sample is taken where the ray meets the grooves' surface, not where it meets the
        plane (Tracer::meetGrooves): 0.645. Bounded at a mean dE of 1.0, past the sample at the
        plane's 1.087."""
        self.check("cluster58", "ring", material="glass", fov_deg=1, resolution=24, look_at=(0.676, -0.589),
                   max_mean=1.0)

    def test_faded_tips_bar(self):
        """The fuzzer's c18_6 (groove_scenes.LAYOUTS["tips"]) under the bar light, seen at 3
        degrees: light scratches crossing deep curved ones whose force fades out over 0.3 mm. The
        polygons take a groove's scale as linear along it; until 2026-11-28 that was the tangent
        at the closest point, which near a fade stood a deep groove's pile-up up to three times its
        height and shadowed the light grooves' lit walls: 0.532% of pixels >= 10 (mean dE 0.51);
        now that groove enters in pieces along its path (Tracer::scaleSegments), 0.174% (0.38);
        0.195% (0.39) since the bends (docs/grooves.md, "Bends"), which its deep curved grooves
        take only where they stray from their tangent by a half-width, and 0.184% (0.39) since
        the leg under the footprint keeps the path's direction; 0.109% (0.37) since its deep
        grooves make the polygons' region span 32 pixel radii, which takes the close views' cap of
        pieces (the integrator's kCloseReach); 0.011% (0.333) later, and 0.076% (0.341) since a
        close view's strata share their polygon surface (the integrator's SharedArea). Bounded at
        0.3%, which the old renderer fails."""
        st = self.check("tips", "bar", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_neighbours_bar(self):
        """Parallel scratches whose pile-ups overlap, under the bar light (groove_scenes.LAYOUTS
        ["neighbours"]): the merged cross-section keeps every pile-up and every groove, as the
        explicit geometry does. When the merge took the lower envelope everywhere, a pair of such
        scratches 0.12 mm apart gave 3.6% of pixels >= 10."""
        self.check("neighbours", "bar")

    def test_fades_bar(self):
        """Short scratches whose force fades from end to end (groove_scenes.LAYOUTS["fades"]) under
        the bar light: the changing depth slopes their walls along the path, as the explicit
        geometry's facets are sloped. When the sections' facets ignored that slope (until
        2026-11-26) this gave mean dE 0.47 and 1.17% of pixels >= 10, the glints on the wrong
        halves of the scratches; now 0.19 and 0%. Under the ring light, all around the lens, the
        slope hardly shows (mean dE 0.145 without it, 0.139 with it, no pixel >= 10), so that
        light is not tested here."""
        self.check("fades", "bar")

    def test_blunt_ends_ring(self):
        """The ends layout with blunt ends (groove_scenes.LAYOUTS["blunt"], fade_mm 0) under the
        ring: a footprint that an end line crosses is integrated by polygons, wherever its centre
        lies. Until 2026-11-28 one whose centre lay just before the end took the groove through the
        whole footprint, drawn at full brightness where the reference has a grey end pixel: mean
        dE 0.176 and no pixel >= 10, but a largest dE of 8.45 there; now 0.171 and 3.35."""
        st = self.check("blunt", "ring")
        print("blunt     ring  largest dE %.2f" % st["max"], flush=True)
        self.assertLess(st["max"], 6.0)

    def test_corners_ring(self):
        """A scratch that turns four corners (groove_scenes.LAYOUTS["zigzag"]) under the ring light:
        polygons give each corner its two legs and the round outer side (docs/grooves.md,
        "Corners"). Until 2026-11-29 the groove at a corner was one straight line, and the outer
        side of each corner a blunt spur: 1.07% of pixels >= 10 (mean dE 0.59); now 0% (0.18).
        Bounded at 0.25%, which the old renderer fails under either light."""
        st = self.check("zigzag", "ring", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.25)

    def test_corners_bar(self):
        """The same under the bar light: 0.61% of pixels >= 10 (mean dE 0.50) before the
        corners, now 0% (0.25)."""
        st = self.check("zigzag", "bar", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.25)

    def test_doubling_bar(self):
        """A scratch that doubles back, turning 179 degrees (groove_scenes.LAYOUTS["doubling"]),
        under the bar light. Until 2026-11-29 a turn past 175 degrees was not a corner (the legs
        ran on straight past the vertex), and two passes of one path were partitioned by nearness
        only where neither was in pieces along its force fade; composited, the returning leg showed
        its lit wall where the nearer leg cuts it away: 2.33% of pixels >= 10 (mean dE 1.80), now
        0.033% (0.228); with the split alone 0.38% against geometry at 512 spp, the rest at the
        tip. Bounded at 0.3%."""
        st = self.check("doubling", "bar", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_retrace_bar(self):
        """A scratch that goes exactly back over itself (groove_scenes.LAYOUTS["retrace"]) under
        the bar light. Until 2026-11-30 a half turn was no corner (the legs ran straight on past
        the vertex), and the two passes, lying on one line, were split along it, a step between
        their cross-sections where the perturbed force differs: 1.74% of pixels >= 10 (mean dE
        0.779), past the target; now 0.033% (0.221).
        Bounded at 0.2%."""
        st = self.check("retrace", "bar", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.2)

    def test_turnback_bar(self):
        """A scratch that goes back along itself for 0.1 mm and then turns away
        (groove_scenes.LAYOUTS["turnback"]) under the bar light. Until 2026-11-30 a chain of
        corners with a half turn was refused, and each footprint took its nearest corner alone, a
        leg stopping inside the groove: 0.553% of pixels >= 10 (mean dE 0.405), past the target
        (0.781% and 0.508 before the half turn was a corner); now 0.065% (0.222). Bounded at
        0.3%."""
        st = self.check("turnback", "bar", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_recurve_bar(self):
        """A cubic followed by its own reverse, cut by a tilted tool (groove_scenes.LAYOUTS["recurve"]),
        under the bar light. Until 2026-11-30 the bends of the way out and of the way back were
        simplified apart, so that the two passes' legs crossed at small angles and each held where
        it was the nearer: wedges of the tilted tool's mirrored cross-section along the groove and a
        cap without its glint, 0.803% of pixels >= 10 (mean dE 0.800), past the target; now 0.076%
        (0.181). Bounded at 0.3%."""
        st = self.check("recurve", "bar", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_shortback_ring(self):
        """A scratch that comes back along its own line and ends short of its start
        (groove_scenes.LAYOUTS["shortback"]), under the ring light. Until 2026-11-30 the two
        passes were kept apart near the path's end and split along their common line, the later
        pass's half flat where its force had faded: 0.629% of pixels >= 10 (mean dE 0.350), past
        the target; now 0% (0.109). Bounded at 0.3%."""
        st = self.check("shortback", "ring", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_nearline_ring(self):
        """The shortback path with its coordinates rounded to four decimals
        (groove_scenes.LAYOUTS["nearline"], the retraces fuzzer's r4_19), under the ring light.
        Until 2026-11-30 its way back, 3e-6 rad off the way out's line, was on one line by none of
        the renderers' tests, and the explicit geometry took whichever pass rounded nearer at each
        point: bright speckles along the groove, 0.326% of pixels >= 10 (mean dE 0.240). Now the
        path is put on its line when it is built, and its passes tie as shortback's do: 0% (0.109).
        Bounded at 0.1% and a mean dE of 0.18 (the speckles alone came near the 0.3% of the other
        retracing scenes)."""
        st = self.check("nearline", "ring", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.1)
        self.assertLess(st["mean"], 0.18)

    def test_halftip_dome(self):
        """A tilted tool's half turn seen from 20 mm at 1 degree, 3.6 micrometres per pixel
        (groove_scenes.LAYOUTS["halftip"], the retraces fuzzer's r2_4 cut short), under an even
        sky alone. So close, the polygons' square region is small against the groove, and the cap's
        steep walls send much of the light they pass on down the groove and out of the region.
        Until 2026-11-30 such rays were dropped: a black spot beside the vertex and a dark line
        along the cap's rim, 0.34% of pixels >= 10 (mean dE 0.30). Now they go on in that groove's
        1-D section (the integrator's beyondRegion): 0% (0.115; 0.104 with the cap's sectors
        narrowed by the pixel, fanSector). Bounded at 0.1% and a mean dE of 0.2."""
        st = self.check("halftip", "dome", fov_deg=1, distance_mm=20)
        self.assertLess(st["pct_ge_10"], 0.1)
        self.assertLess(st["mean"], 0.2)

    def test_halftip_ring(self):
        """The same half turn under the ring light, against a reference with cells a quarter of the
        automatic ones (render.geometry_cell_mm 0.0025): the automatic cells, 3 pixels wide here,
        cannot follow the cap's round kinks and drew a bright rectangle where references with
        finer cells agree on a wedge (0.84% of pixels >= 10 between the two). Until 2026-11-30
        the groove renderer's 15-degree fan sectors broke that wedge into streaks: 0.977% of pixels
        >= 10 (mean dE 0.847); now the sectors narrow with the pixel (the integrator's fanSector,
        5 degrees here): 0.076% (0.554). Bounded at 0.2% and a mean dE of 0.7."""
        st = self.check("halftip", "ring", fov_deg=1, distance_mm=20, cell_mm=0.0025)
        self.assertLess(st["pct_ge_10"], 0.2)
        self.assertLess(st["mean"], 0.7)

    def test_halftip_bar(self):
        """The same under the bar light (reference cells as under the ring): 1.584% (mean dE 1.133)
        with 15-degree sectors, 0.206% (0.356) with sectors by the pixel. Bounded at 0.4% and a
        mean dE of 0.6."""
        st = self.check("halftip", "bar", fov_deg=1, distance_mm=20, cell_mm=0.0025)
        self.assertLess(st["pct_ge_10"], 0.4)
        self.assertLess(st["mean"], 0.6)

    def test_spot_bar(self):
        """Eight deep scratches through a spot 0.2 mm across (groove_scenes.LAYOUTS["spot"]) seen at
        1 degree, 32 x 32 pixels, under the bar light. At the polygons' ordinary cap of pieces
        (1,200) 3,171 of its 4,096 footprints passed it at every reach and kept only their nearest
        grooves, and the image had little to do with the reference: 50% of pixels >= 10 (mean dE
        20.1). Seen this close the cap was 4,000 (the integrator's kCloseReach): no footprint is
        left with only its nearest grooves, 0.49% (1.23), the same at 16 spp
        (0.49%, 1.14), so what is left is not noise; 0.59% (1.22) since its strata share their
        polygon surface (the integrator's SharedArea). With the close views' cap at 16,000 pieces
        (the fifty-second session) 0.59% (1.28), and at 16 spp 0.39% (1.05) where 4,000 gave 0.49%
        (1.12); with up to four side pieces per groove in a fade (integrator's scaleSegments, the same
        session) 0.78% (1.36), and 0.59% (1.14) at 16 spp. The issue's target (< 0.5%, mean dE < 1) is
        for its three scenes; this one is bounded at 1.5% and a mean dE of 1.6."""
        self.check("spot", "bar", fov_deg=1, resolution=32, max_pct=1.5, max_mean=1.6)

    def test_fading_ends_in_pieces_bar(self):
        """Six scratches crossing near one spot, each with 0.3 mm fades at its ends
        (groove_scenes.LAYOUTS["fades6"], the clusters fuzzer's c56_1), seen at 1 degree from 15 mm
        (11 micrometres per pixel), 24 x 24 pixels, under the bar light with direct light only
        (max_bounces 1). Each groove whose fade lies in a footprint's region enters its polygons
        in three pieces along its path (the integrator's scaleSegments). Until the fifty-second
        session each piece counted as a groove against the surface's cap of 16: 18 of them passed
        it where the six whole grooves did not, so the region took them whole, their fading ends
        at full depth, and lit walls stood where the reference's ends have faded out: 8.3% of
        pixels >= 10 (mean dE 4.53). As one groove of parts each (groove_area's pieceParts): 0%
        (0.52; 0.41 with the finer pieces of the next test)."""
        self.check("fades6", "bar", fov_deg=1, distance_mm=15, resolution=24, max_bounces=1)

    def test_fading_ends_two_bounces_bar(self):
        """The same view with the light one wall passes to another (max_bounces 2): the walls of
        the crossing send the view down the grooves to pile-ups up to 0.4 mm away, which mirror it
        into the bar. A groove in pieces had one piece on either side of the footprint's stretch,
        linear out to the end of the reach: from a fade near the footprint across the plateau to
        the far end's fade in one line, which put a pile-up 0.4 mm away at 0.61 of its scale
        instead of 0.88, low enough for that light to pass over it. With up to four pieces on
        either side (the fifty-second session): 0.35% of pixels >= 10 (mean dE 1.52) against 3.1%
        (2.29), against geometry at 2,048 spp (the light over rare paths needs it: at 1,024 the
        reference puts 0.87% of pixels >= 10 on the same render). Bounded at 1% and a mean dE of 2."""
        self.check("fades6", "bar", fov_deg=1, distance_mm=15, resolution=24, max_bounces=2, ref_spp=2048, max_pct=1.0,
                   max_mean=2.0, name="fades6_bar_2b")

    def test_nearly_parallel_bar(self):
        """Two deep scratches (75 and 64 micrometres) side by side whose arcs bend opposite ways
        (groove_scenes.LAYOUTS["nearpar58"], the lines fuzzer's l58_6), one spot of them seen at 1
        degree from 30 mm (22 micrometres per pixel), 24 x 24 pixels, under the bar light. Where
        they are within 2 degrees of parallel the footprints merge them into one section along the
        deeper one's direction. The other one's walls, turned by up to 2 degrees about the
        vertical, mirror the bar (over the opposite wall) nearly 3 degrees off, and its highlight
        broke off where the reference's fades out along the path: 7.3% of pixels >= 10 (mean dE
        3.01). With each groove's facets keeping their own normals (PlacedProfile::turn, the
        fifty-third session): 0% (1.35). Bounded at 0.5% and a mean dE of 2."""
        self.check("nearpar58", "bar", fov_deg=1, distance_mm=30, resolution=24, look_at=(-0.2, 0.05), max_mean=2.0)

    def test_vertex_beside_leg_bar(self):
        """A tilted tool's corner of 156 degrees whose path's last leg passes 0.7 micrometres from
        its vertex, under another scratch's legs (groove_scenes.LAYOUTS["vertex60"], the corners
        fuzzer's c60_0), one spot of it seen at 1 degree from 30 mm (22 micrometres per pixel), 24 x
        24 pixels, under the bar light. The points nearer the vertex than the leg lie in a narrow
        parabola, which the fan's 10-degree sectors cut along chords far from the curve: a strip of
        the cap (20 micrometres high) went to the leg's flat side, and the other scratch's pile-up
        glinted where the cap covers it. With the fan refined about the leg's axis (the fifty-fourth
        session), at 8 spp: 0.174% of pixels >= 10 (mean dE 0.929) against 2.60% (1.71). At 4 spp the
        light over two walls is noisier this close (0.174%, mean 1.31, against 3.65%, 2.07).
        Bounded at 0.5% and a mean dE of 1.2."""
        self.check("vertex60", "bar", fov_deg=1, distance_mm=30, resolution=24, look_at=(-0.50, 0.21), spp=8,
                   max_mean=1.2)

    def test_rise_over_pileups_ring(self):
        """A tilted tool's corner of 145 degrees with a later leg of its path 1 to 1.2 mm beyond it
        (groove_scenes.LAYOUTS["rise60"], the corners fuzzer's c60_2), seen as the fuzzer saw it:
        1 degree from 60 mm (22 micrometres per pixel), 48 x 48 pixels, under the ring light. The
        foot of the corner's pile-up sends the camera's rays out just above the plate; those within
        about a degree of it meet the later leg's inner face, which mirrors the ring down into them.
        Before rising rays were marched over the pile-ups beyond the polygons' region
        (pileUpAhead), they went on as ordinary rays against the flat part and met nothing: a dark
        strip along the foot, 0.781% of pixels >= 10 (mean 0.694); now 0% (0.575). (A crop of the
        spot seen from 30 mm did not show it: the ring sits round the lens, and from 30 mm its light
        comes from 34 to 45 degrees off the normal, not 18 to 27.)"""
        self.check("rise60", "ring", fov_deg=1, resolution=48, spp=8)

    def test_channel_past_a_turn_bar(self):
        """A groove crossing a tilted tool's groove on a leg that a turn of 148 degrees ends 0.8 mm
        on (groove_scenes.LAYOUTS["channel68"], the corners fuzzer's c68_4), seen as the fuzzer saw
        it: red car paint, 1 degree from 60 mm, 48 x 48 pixels, under the bar light. Rays that the
        tilted groove's pile-up sends out just above the plate, nearly along that leg, leave the
        polygons' region downwards beside it; the leg's 1-D section (beyondRegion) ran on past the
        turn, and its pile-up there, which is not there, mirrored the bar into them: a glint on the
        pile-up twice as long as the reference's, 0.651% of pixels >= 10 (mean 0.46). Marched over
        the explicit geometry's height, they meet the plate past the turn and go on as ordinary
        rays: 0.043% (0.35)."""
        self.check("channel68", "bar", material="paint", fov_deg=1, resolution=48, spp=8)

    def test_cluster_twelve_radii_bar(self):
        """Thirteen crossing scratches under the bar light (groove_scenes.LAYOUTS["cluster58b"], the
        clusters fuzzer's c58_4), one spot of it seen at 1 degree from 60 mm (44 micrometres per
        pixel), 24 x 24 pixels. Their reach toward the low bar is about 12 of a pixel's radii,
        below the 16 at which the close views' cap of pieces began: at the ordinary cap of 1,200
        the crossings were built over a half or a quarter of the reach, or with only their nearest
        grooves, and lost glints and shadows from the rest. With the close views from 8 radii
        (the fifty-third session), at 8 spp: 0% of pixels >= 10 (mean dE 1.24) against 1.91%
        (1.63), in the same time. At 4 spp the light over two walls is too noisy this close to
        tell them apart (1.04% against 2.78%). Bounded at 0.5% and a mean dE of 1.5."""
        self.check("cluster58b", "bar", fov_deg=1, resolution=24, look_at=(-0.175, 0.153), spp=8,
                   max_mean=1.5)

    def test_cluster_close_bar(self):
        """Twelve deep scratches crossing in a cluster (groove_scenes.LAYOUTS["cluster56"], the
        clusters fuzzer's c56_1) seen at 1 degree, 24 x 24 pixels, under the bar light: the light
        the walls pass between them needs the polygons over the full reach, 8,000 to 16,000 pieces
        there. At the close views' earlier cap of 4,000 the crossings were built over half the
        reach and lost it: 13.2% of pixels >= 10 (mean dE 4.86). With 16,000 (the fifty-second
        session) 1.04% (1.60), 1.39% (1.58) with the finer side pieces, in two thirds of the time: a build refused at the cap costs about
        as much as one that passes. Not one of the issue's target scenes; bounded at 2.5% and a
        mean dE of 2.2."""
        self.check("cluster56", "bar", fov_deg=1, resolution=24, max_pct=2.5, max_mean=2.2)

    def test_backforth_bar(self):
        """A scratch that goes back and forth past the view (groove_scenes.LAYOUTS["backforth"]:
        three legs 0.1 mm apart, their grooves overlapping) under the bar light. Until 2026-11-29
        the polygons split only two passes of one path by nearness and composited a third, which
        showed where a footprint near enough both legs of a vertex went to them: 0.684% of pixels
        >= 10 (mean dE 0.720), past the target; now 0.087% (0.390). Bounded at 0.3%."""
        st = self.check("backforth", "bar", fov_deg=1.5)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_tipcorners_bar(self):
        """A cubic hairpin whose tip flattens into corners (groove_scenes.LAYOUTS["tipcorners"], the
        passes fuzzer's p3_18) under the bar light, seen at 1 degree. Until 2026-11-29 a pass with
        corners was given its bends only where its path strayed from the tangent at its closest
        point, though its groove is the corners' straight legs: the last leg ran straight on where
        the path curves away, a glint on flat plate: 0.336% of pixels >= 10 (mean dE 0.442); now
        0.076% (0.268), and 0.098% (0.268) since a close view's strata share their polygon surface
        (the integrator's SharedArea). Bounded at 0.2%."""
        st = self.check("tipcorners", "bar", fov_deg=1)
        self.assertLess(st["pct_ge_10"], 0.2)

    def test_loop_ring(self):
        """A scratch whose path loops back across itself (groove_scenes.LAYOUTS["loop"]: a cubic
        curve crossing its own way at 78 degrees, seen at 3 degrees) under the ring light. Each pass
        of the path near a footprint is a groove, and where their cross-sections overlap each
        holds where it is the nearer, as in the reference (docs/grooves.md, "A path that comes
        back"). Until 2026-11-29 a footprint saw only the pass nearest it: 0.033% of pixels >= 10
        (mean dE 0.177) here, now 0% (0.163). Bounded at 0.15%, which the old renderer fails under
        the bar."""
        st = self.check("loop", "ring", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.15)

    def test_loop_bar(self):
        """The same under the bar light: 0.206% of pixels >= 10 (mean dE 0.341) before, now 0.065%
        (0.286). Before, the other pass's walls neither shadowed nor lit the footprint, and at the
        crossing the explicit geometry's step between the two passes' depths was missing. Since the
        bends (docs/grooves.md, "Bends"), where the loop's passes are runs of one partition,
        0.141% (0.310), with the glints beside the crossing moved toward it: the chord under the
        footprint turned from the path by a few degrees. Since that leg keeps the path's own
        direction, 0.043% (0.282). Bounded at 0.1%."""
        st = self.check("loop", "bar", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.1)

    def test_hairpin_ring(self):
        """A path that turns back beside itself (groove_scenes.LAYOUTS["hairpin"]: legs 0.12 mm
        apart whose grooves overlap, the turn out of view) under the ring light. In the sections
        each leg holds on its side of their midline, as in the reference (docs/grooves.md, "A path
        that comes back"). Until 2026-11-29 a footprint saw only the nearer leg: 3.81% of pixels
        >= 10 (mean dE 1.35), past the target; now 0% (0.14). Bounded at 0.25%."""
        st = self.check("hairpin", "ring", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.25)

    def test_hairpin_bar(self):
        """The same under the bar light: 2.21% of pixels >= 10 (mean dE 1.12) before, now 0.033%
        (0.30)."""
        st = self.check("hairpin", "bar", fov_deg=3)
        self.assertLess(st["pct_ge_10"], 0.25)

    def test_tiltpin_bar(self):
        """A tilted tool's polyline turning back by 162 degrees, crossed by two deep straight
        scratches (groove_scenes.LAYOUTS["tiltpin"], the corner fuzzer's c41_7) under the bar light,
        seen at 1 degree, 48 x 48 pixels (22 micrometres each). The straight grooves reach 23 pixel
        radii toward the light; the polygons' region there holds more pieces than the ordinary cap,
        and a footprint built over half the reach lost the straight grooves' shadows beyond it:
        the glints along the turn's walls reached a pixel or two too far, 0.477% of pixels >= 10
        (mean dE 0.857) until the close views began at 16 pixel radii instead of 32 (the
        integrator's kCloseReach); now 0.043% (0.666), and (0.663) with the strata's polygon surface
        shared (SharedArea), in 3.7 s instead of 6.6. Bounded at 0.2%."""
        st = self.check("tiltpin", "bar", fov_deg=1, resolution=48)
        self.assertLess(st["pct_ge_10"], 0.2)

    def test_tightloop_backlight(self):
        """A cubic that loops tightly across its own way (groove_scenes.LAYOUTS["tightloop"], the
        passes fuzzer's p45_3) on the glass lens under the back light, seen at 1 degree, 48 x 48
        pixels. Where the loop's later pass lay outside the window of the earlier pass's bends, both
        stood their two corners' straight legs, and a leg ran across the loop 0.06 mm off the path:
        a dark arc on the clear glass beside the groove, 2.08% of pixels >= 10 (mean dE 1.24); now
        each pass takes its own bends, 0% (0.50); 0% (0.48) since the strata share their polygon
        surface (the integrator's SharedArea). Bounded at 0.2%."""
        st = self.check("tightloop", "backlight", material="glass", fov_deg=1, resolution=48)
        self.assertLess(st["pct_ge_10"], 0.2)

    def test_hook_bar(self):
        """A path that crosses its own earlier leg 0.16 mm from a corner (groove_scenes.LAYOUTS
        ["hook"], seen at 2 degrees) under the bar light. The corner's legs and the crossed leg are
        runs of one partition, each holding where it is the nearer (docs/grooves.md, "A path that
        comes back"). Until 2026-11-29 the corner groove and the crossed leg's straight groove were
        composited, each pass's pile-up standing over the other's groove where they cross:
        0.553% of pixels >= 10 (mean dE 0.352), past the target; now 0.011% (0.192). Bounded at
        0.1%. (Under the ring light it was 0.011% (0.20), now 0% (0.17): not a case of its own.)"""
        st = self.check("hook", "bar", fov_deg=2)
        self.assertLess(st["pct_ge_10"], 0.1)

    def test_knot_ring(self):
        """A path that turns three corners within a groove's width or two (groove_scenes.LAYOUTS
        ["knot"], seen at 2 degrees) under the ring light. The polygons take the corners near a
        footprint together and split the surface by nearness to their legs and round outer sides
        (groove::area::chainParts; docs/grooves.md, "Corners close together"). Until 2026-11-29 a
        footprint took one corner, whose legs stopped at the next corners inside the groove:
        0.239% of pixels >= 10 (mean dE 0.259), now 0% (0.153). Bounded at 0.1%."""
        st = self.check("knot", "ring", fov_deg=2)
        self.assertLess(st["pct_ge_10"], 0.1)

    def test_knot_bar(self):
        """The same under the bar light: 0.814% of pixels >= 10 (mean dE 0.408), past the target,
        before; 0.098% (0.220) with the chains of corners, and 0.054% (0.203) since the bends
        (docs/grooves.md, "Bends") let more of its chains through; (0.205) with the strata's polygon
        surface shared (the integrator's SharedArea). Bounded at 0.3%."""
        st = self.check("knot", "bar", fov_deg=2)
        self.assertLess(st["pct_ge_10"], 0.3)

    def test_curl_ring(self):
        """A cubic that curls into a loop about 0.3 mm across (groove_scenes.LAYOUTS["curl"], seen
        at 2 degrees) under the ring light. The polygons follow the path's bends near the
        footprint, simplified to within a twentieth of its radius there and more farther away
        (ScratchPath::bendsAround; docs/grooves.md, "Bends"). Before 2026-11-29 the straight legs
        between the loop's corners, and the tangent where a pass had none, ran across it: 5.82% of
        pixels >= 10 (mean dE 3.42), then 0.130% (0.197); since the forty-fifth session, where a
        later pass lies outside the earlier one's window it takes its own bends instead of both
        passes' corner legs, 0% (0.164); 0% (0.160) since a close view's strata share their polygon
        surface (the integrator's SharedArea). Bounded at 0.4%."""
        st = self.check("curl", "ring", fov_deg=2)
        self.assertLess(st["pct_ge_10"], 0.4)

    def test_curl_bar(self):
        """The same under the bar light: 4.24% of pixels >= 10 (mean dE 2.38) before, 0.043%
        (0.249) with the bends, then 0% (0.211): where chainParts refuses a chain of 16 bends at
        its caps, 8 or 4 are tried before the tangent; 0% (0.208) since a later pass outside the
        window takes its own bends; 0.043% (0.232), one pixel, since the strata share their polygon
        surface (SharedArea). Bounded at 0.4%."""
        st = self.check("curl", "bar", fov_deg=2)
        self.assertLess(st["pct_ge_10"], 0.4)

    def test_dense_crossings_bar(self):
        """Six scratches crossed by six (groove_scenes.LAYOUTS["dense"]) under the bar light: at the
        full shadow reach a crossing's pieces pass their cap; the polygons are then built over
        half or a quarter of the reach, and no footprint falls back to the blend. With the blend
        there (measured 2026-11-26) it gave mean dE 1.63 and 2.27% of pixels >= 10; now 0.52 and
        0.02%."""
        self.check("dense", "bar")
        used = footprints("dense_bar_groove")
        print("dense     bar   footprints %s" % used, flush=True)
        self.assertEqual((used["trimmed"], used["fallbacks"]), (0, 0))
        self.assertGreater(used["polygons"], 0)

    def test_star_past_the_polygon_caps(self):
        """Twelve grooves through one spot: footprints whose pieces pass the cap even within a
        quarter of the shadow reach are past the polygons' caps, and are integrated by polygons
        over the grooves nearest them (docs/grooves.md, "Cost bound and fallback"; with the cap of
        8 grooves before 2026-11-30, 50 footprints, with 16, 27 and the same figures). Not one of the issue's target scenes; the bounds are regression bounds
        (measured against geometry at 256 spp, whose own noise against a second reference is
        0.12% of pixels >= 10 and mean 0.45: 2026-11-25 1.53% and 0.91; 2026-11-26, with the
        smaller reaches, 0.71% and 0.66; with the cap of pieces at 1,200 instead of 600, 0.35% and
        0.48; 2026-11-28, with the lobe choice stratified over the pixel, 0.32% and 0.49, with 709
        footprints on the blend, 659 of them at the scratches' faded tips (polygons since, the same
        figures); the 50 past the caps on the nearest grooves instead of the blend: 0.13% and
        0.43)."""
        self.check("star", "bar", ref_spp=256, max_pct=0.25, max_mean=0.5, past_caps=True)
        used = footprints("star_bar_groove")
        print("star      bar   footprints %s" % used, flush=True)
        self.assertGreater(used["polygons"], 0)

    def test_groups_ring(self):
        """Three groups of scratches crossing near the view's centre (groove_scenes.LAYOUTS
        ["groups"], the clusters fuzzer's c52_5) under the ring light, seen at 2 degrees, 48 x 48
        pixels. Beside the crossings the polygons pass their caps at the full and the half reach
        with the curved grooves in pieces, and fit at the half reach with each groove whole. Until
        the fiftieth session the pieces were tried at every reach first and the region was built
        over a quarter of the reach: the bands of crossings lost the ring's light bounced off the
        walls beyond it and were darker than the reference, 0.694% of pixels >= 10 (mean dE
        0.899); now 0.043% (0.577) (docs/grooves.md, "Fading tips in the polygons"). Its
        centre is past the caps at every reach (trimmed footprints), so this is a regression
        bound, not one of the issue's target scenes: 0.25% and a mean of 0.75."""
        self.check("groups", "ring", max_pct=0.25, max_mean=0.75, past_caps=True, fov_deg=2, resolution=48)


def _make(layout, light):
    def test(self):
        self.check(layout, light)
    return test


for _layout, _light in groove_scenes.SCENES:
    setattr(GrooveAccuracy, "test_%s_%s" % (_layout, _light), _make(_layout, _light))


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--binary", required=True)
    ap.add_argument("--work", required=True)
    ARGS, rest = ap.parse_known_args()
    os.makedirs(ARGS.work, exist_ok=True)
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
