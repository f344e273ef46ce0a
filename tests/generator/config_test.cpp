#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "core/error.h"
#include "core/fsutil.h"
#include "generator/config.h"

using namespace dg;

namespace {

const char* kMinimal = R"(part:
  type: plate
lights:
  - type: dome
camera:
  fov_deg: 40
  position: [0, 0, 500]
)";

// Returns the InputError's message, or "" if parsing succeeded.
std::string errorOf(const std::string& yaml) {
  try {
    parseConfig(yaml, "test.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// A bad file's bytes quoted in a message: a NUL used to end the message early (what() is a C
// string), a newline or vertical tab to break it. They are shown as '?' (found by fuzzing compare's
// --pairs CSV).
TEST(InputError, ControlCharactersInTheMessageAreShownAsQuestionMarks) {
  const char raw[] = "unknown column '\0\n\x0b\x7f' in the header";
  const InputError e("pairs.csv", 1, 0, std::string(raw, sizeof raw - 1));
  EXPECT_STREQ(e.what(), "pairs.csv:1: unknown column '\?\?\?\?' in the header");
  EXPECT_EQ(InputError("a.obj", "caf\xc3\xa9").what(), std::string("a.obj: caf\xc3\xa9"));  // UTF-8 is kept
}

// YAML forbids a key twice in one mapping; yaml-cpp keeps both and answers with the first, so a
// `seed: 99` added at the end of a file that already had `seed: 7` was silently ignored.
TEST(Config, AKeyGivenTwiceIsRefused) {
  std::string e = errorOf(std::string(kMinimal) + "seed: 3\nseed: 4\n");
  EXPECT_NE(e.find("test.yaml:9:1: 'seed' is given twice in one mapping (first at line 8); keep one"), std::string::npos) << e;
  e = errorOf(std::string(kMinimal) + "defects:\n  - {type: dent, radius_mm: 5, radius_mm: 6}\n");
  EXPECT_NE(e.find("test.yaml:9:32: 'radius_mm' is given twice"), std::string::npos) << e;
  EXPECT_EQ(errorOf(std::string(kMinimal) + "defects:\n  - {type: dent, radius_mm: 5}\n  - {type: dent, radius_mm: 6}\n"), "");
}

// YAML's merge key, `<<: *name`, which yaml-cpp leaves as an ordinary key (it was "missing
// 'type'" at the merging mapping).
TEST(Config, MergeKeysShareSettings) {
  const std::string base = std::string(kMinimal) +
                           "dent: &dent {type: dent, radius_mm: 20, depth_mm: 1}\n"  // line 8
                           "big: &big {radius_mm: 40}\n"
                           "defects:\n"
                           "  - <<: *dent\n"
                           "  - <<: *dent\n"
                           "    depth_mm: 2\n"
                           "  - <<: [*big, *dent]\n";
  // The anchors' own keys are not config fields.
  std::string e = errorOf(base);
  EXPECT_NE(e.find("test.yaml:8:1: unknown key 'dent'"), std::string::npos) << e;
  const std::string text = std::string(kMinimal) +
                           "defects:\n"
                           "  - &dent {type: dent, radius_mm: 20, depth_mm: 1}\n"  // line 9
                           "  - <<: *dent\n"
                           "    depth_mm: 2\n"
                           "  - <<: [{radius_mm: 40}, *dent]\n";
  Config c = parseConfig(text, "test.yaml");
  const auto& d = c.root["defects"].items;
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d[1]["type"].str(), "dent");
  EXPECT_DOUBLE_EQ(d[1]["radius_mm"].num(), 20);
  EXPECT_DOUBLE_EQ(d[1]["depth_mm"].num(), 2);  // the mapping's own key wins
  EXPECT_DOUBLE_EQ(d[2]["radius_mm"].num(), 40);  // of a list, the first mapping wins
  EXPECT_DOUBLE_EQ(d[2]["depth_mm"].num(), 1);
  // A merged value that is wrong is named where the anchor gives it.
  e = errorOf(std::string(kMinimal) + "defects:\n  - &dent {type: dent, radius_mm: -5}\n  - <<: *dent\n");
  EXPECT_NE(e.find("test.yaml:9:35: 'defects[0].radius_mm': -5 is out of range"), std::string::npos) << e;
  e = errorOf(std::string(kMinimal) + "defects:\n  - <<: 3\n");
  EXPECT_NE(e.find("test.yaml:9:9: '<<' (merge key): expected a mapping"), std::string::npos) << e;
  // Quoted, it is an ordinary key.
  e = errorOf(std::string(kMinimal) + "defects:\n  - {type: dent, '<<': {radius_mm: 5}}\n");
  EXPECT_NE(e.find("unknown key '<<'"), std::string::npos) << e;
}

// YAML::Load read the first document and dropped a second one appended after '---' without a word.
TEST(Config, ASecondDocumentIsRefused) {
  std::string e = errorOf(std::string(kMinimal) + "---\nseed: 5\n");
  EXPECT_NE(e.find("test.yaml:9:1: a second YAML document begins here; a config is one document"), std::string::npos)
      << e;
  EXPECT_EQ(errorOf(std::string(kMinimal) + "---\n"), "");  // an empty one at the end is let pass
  EXPECT_EQ(errorOf("---\n" + std::string(kMinimal)), "");
}

// A ',' where a document's value should begin made yaml-cpp 0.7's LoadAll return empty documents
// for ever, each a new node, until memory ran out (a fuzzed config whose comment lost its '#').
TEST(Config, AStrayCommaIsRefusedNotLoopedOn) {
  std::string e = errorOf("# a comment\n, the rest of it\n" + std::string(kMinimal));
  EXPECT_NE(e.find("test.yaml:2:1: malformed YAML: a value cannot begin with ','"), std::string::npos) << e;
  e = errorOf(std::string(kMinimal) + "---\n,\n");  // in a second document too
  EXPECT_NE(e.find("test.yaml:9:1: malformed YAML: a value cannot begin with ','"), std::string::npos) << e;
}

TEST(Config, YamlTagsAreRefused) {
  // Each value is read by its field's type, so a tag was dropped without a word ('!!str 40' read
  // as 40, '!include x.yaml' as its bare file name).
  const std::string base = kMinimal;
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string t = base;
    t.replace(t.find(from), from.size(), to);
    return errorOf(t);
  };
  for (const char* tag : {"!!str", "!!float", "!include", "!ENV"}) {
    const std::string e = replaced("fov_deg: 40", std::string("fov_deg: ") + tag + " 40");
    EXPECT_NE(e.find(std::string("test.yaml:6:12: YAML tag '") + tag + "' is not supported"), std::string::npos)
        << tag << ": " << e;
  }
  EXPECT_EQ(replaced("fov_deg: 40", "fov_deg: ! 40"), "");  // the non-specific tag, as on a quoted scalar
  EXPECT_EQ(replaced("fov_deg: 40", "fov_deg: !!int 40").find("test.yaml:6:12: YAML tag '!!int'"), 0u);
  // On a key and on a mapping too.
  EXPECT_EQ(replaced("fov_deg: 40", "!!str fov_deg: 40").find("test.yaml:6:3: YAML tag '!!str'"), 0u);
  EXPECT_EQ(replaced("camera:\n", "camera: !!map\n").find("test.yaml:5:9: YAML tag '!!map'"), 0u);
}

TEST(Config, AShellPathIsExplained) {
  // '~' and $HOME are the shell's; the path was reported as not found with no hint why.
  const std::string base = kMinimal;
  for (const char* given : {"~/parts/door.obj", "$HOME/parts/door.obj", "${PARTS}/door.obj"}) {
    std::string t = base;
    t.replace(t.find("type: plate"), 11, std::string("{type: mesh, path: '") + given + "'}");
    const std::string e = errorOf(t);
    EXPECT_NE(e.find(std::string("file not found: ") + given + " (a config does not expand '~' or $VARIABLES"),
              std::string::npos)
        << e;
  }
  std::string t = base;
  t.replace(t.find("type: plate"), 11, "{type: mesh, path: parts/door.obj}");
  EXPECT_EQ(errorOf(t).find("expand"), std::string::npos);  // no hint for an ordinary missing file
}

TEST(Config, SceneHashLeavesOutTheCountAlone) {
  const std::string base = kMinimal;
  const Config a = parseConfig("count: 3\n" + base, "test.yaml");
  const Config b = parseConfig("count: 7\n" + base, "test.yaml");
  const Config c = parseConfig("count: 3\nseed: 9\n" + base, "test.yaml");
  const Config d = parseConfig("count: 3\n" + base + "render: {spp: 4}\n", "test.yaml");
  EXPECT_NE(a.hash(), b.hash());
  EXPECT_EQ(a.sceneHash(), b.sceneHash());
  EXPECT_NE(a.sceneHash(), c.sceneHash());  // the seed is part of it (generate also compares it)
  EXPECT_NE(a.sceneHash(), d.sceneHash());
  EXPECT_NE(a.sceneHash(), a.hash());
}

TEST(Config, MinimalConfigGetsEveryDefault) {
  Config c = parseConfig(kMinimal, "test.yaml");
  EXPECT_EQ(c.root["part"]["type"].str(), "plate");
  EXPECT_DOUBLE_EQ(c.root["part"]["width_mm"].num(), 300);
  EXPECT_TRUE(c.root["part"]["width_mm"].defaulted);
  EXPECT_EQ(c.root["material"]["type"].str(), "car_paint");
  EXPECT_DOUBLE_EQ(c.root["render"]["spp"].num(), 16);
  EXPECT_EQ(c.root["render"]["resolution"].items.size(), 2u);
  EXPECT_TRUE(c.root["defects"].items.empty());
  EXPECT_EQ(c.root["camera"]["up"].items[1].num(), 1.0);
  std::string d = describeConfig(c);
  EXPECT_NE(d.find("width_mm: 300"), std::string::npos) << d;
  EXPECT_NE(d.find("# mm, default"), std::string::npos) << d;
  EXPECT_NE(d.find("spp: 16"), std::string::npos) << d;
}

TEST(Config, MalformedYamlNamesLineAndColumn) {
  std::string e = errorOf("part:\n  type: plate\n  width_mm: [1, 2\n");
  EXPECT_NE(e.find("test.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed YAML"), std::string::npos) << e;
}

TEST(Config, UnknownKeySuggestsClosest) {
  std::string e = errorOf(std::string(kMinimal) + "render:\n  spp: 4\n  max_bounce: 3\n");
  EXPECT_NE(e.find("test.yaml:10:3"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key 'max_bounce'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'max_bounces'"), std::string::npos) << e;
  std::string e2 = errorOf(std::string(kMinimal) + "defects:\n  - type: dnet\n");
  EXPECT_NE(e2.find("did you mean 'dent'"), std::string::npos) << e2;
}

TEST(Config, WrongTypeIsReported) {
  std::string e = errorOf(std::string(kMinimal) + "render:\n  spp: many\n");
  EXPECT_NE(e.find("test.yaml:9:8"), std::string::npos) << e;
  EXPECT_NE(e.find("expected a number"), std::string::npos) << e;
  std::string e2 = errorOf(std::string(kMinimal) + "render:\n  spp: 2.5\n");
  EXPECT_NE(e2.find("expected an integer"), std::string::npos) << e2;
  std::string e3 = errorOf(std::string(kMinimal) + "render:\n  exr: maybe\n");
  EXPECT_NE(e3.find("expected true or false"), std::string::npos) << e3;
  std::string e4 = errorOf(std::string(kMinimal) + "render:\n  resolution: [512]\n");
  EXPECT_NE(e4.find("expected a list of 2 numbers"), std::string::npos) << e4;
}

TEST(Config, OutOfRangeIsReportedWithRangeAndUnit) {
  std::string e = errorOf(std::string(kMinimal) + "defects:\n  - type: dent\n    radius_mm: -3\n");
  EXPECT_NE(e.find("test.yaml:10:16"), std::string::npos) << e;
  EXPECT_NE(e.find("'defects[0].radius_mm'"), std::string::npos) << e;
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  EXPECT_NE(e.find("mm"), std::string::npos) << e;
  // Distribution bounds are range-checked too.
  std::string e2 = errorOf(std::string(kMinimal) + "defects:\n  - type: dent\n    radius_mm: {uniform: [1, 9000]}\n");
  EXPECT_NE(e2.find("out of range"), std::string::npos) << e2;
}

TEST(Config, MissingFileAndMissingRequiredKeys) {
  try {
    loadConfig("/nonexistent/dir/x.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.yaml"), std::string::npos);
  }
  std::string e = errorOf("lights:\n  - type: dome\ncamera:\n  fov_deg: 40\n  position: [0, 0, 500]\n");
  EXPECT_NE(e.find("missing required key 'part'"), std::string::npos) << e;
  std::string e2 = errorOf("part:\n  type: mesh\n  path: no_such_mesh.obj\nlights:\n  - type: dome\ncamera:\n"
                           "  fov_deg: 40\n  position: [0, 0, 500]\n");
  EXPECT_NE(e2.find("test.yaml:3:9"), std::string::npos) << e2;
  EXPECT_NE(e2.find("file not found"), std::string::npos) << e2;
  // A folder or a device where a file is expected is named as such.
  std::string e3 = errorOf("part:\n  type: mesh\n  path: /tmp\nlights:\n  - type: dome\ncamera:\n"
                           "  fov_deg: 40\n  position: [0, 0, 500]\n");
  EXPECT_NE(e3.find("test.yaml:3:9: 'part.path': is a folder, expected a file: /tmp"), std::string::npos) << e3;
  std::string e4 = errorOf("part:\n  type: mesh\n  path: /dev/null\nlights:\n  - type: dome\ncamera:\n"
                           "  fov_deg: 40\n  position: [0, 0, 500]\n");
  EXPECT_NE(e4.find("'part.path': is not a regular file: /dev/null"), std::string::npos) << e4;
}

TEST(Config, CrossFieldRules) {
  std::string both = "part:\n  type: plate\nlights:\n  - type: dome\ncamera:\n  fov_deg: 40\n"
                     "  intrinsics: [500, 500, 256, 256]\n  position: [0, 0, 500]\n";
  EXPECT_NE(errorOf(both).find("exactly one of"), std::string::npos);
  std::string ring = std::string(kMinimal) + "  - type: ring\n    radius_mm: 10\n    inner_radius_mm: 20\n";
  // (appended to the camera block, so put lights in properly instead)
  std::string ring_cfg = "part:\n  type: plate\nlights:\n  - type: ring\n    radius_mm: 10\n    inner_radius_mm: 20\n"
                         "camera:\n  fov_deg: 40\n  position: [0, 0, 500]\n";
  EXPECT_NE(errorOf(ring_cfg).find("smaller than radius_mm"), std::string::npos) << errorOf(ring_cfg);
  std::string two_env = "part:\n  type: plate\nlights:\n  - type: dome\n  - type: dome\n"
                        "camera:\n  fov_deg: 40\n  position: [0, 0, 500]\n";
  EXPECT_NE(errorOf(two_env).find("only one environment"), std::string::npos);
  EXPECT_NE(errorOf(std::string(kMinimal) + "part2: 1\n").find("did you mean 'part'"), std::string::npos);
  // The part is fixed for a dataset: no distributions there.
  std::string rnd = "part:\n  type: plate\n  width_mm: {uniform: [100, 200]}\nlights:\n  - type: dome\n"
                    "camera:\n  fov_deg: 40\n  position: [0, 0, 500]\n";
  EXPECT_NE(errorOf(rnd).find("must be a constant"), std::string::npos) << errorOf(rnd);
  // A tool tilt that would put the tool's flank or edge below its tip, named at the tilt with the
  // limit for that tool; with distributions, for the largest tilt and apex they can draw.
  auto scratch = [](const std::string& keys) {
    return std::string(kMinimal) + "defects:\n  - type: scratch\n" + keys;
  };
  EXPECT_EQ(errorOf(scratch("    tool_apex_deg: 170\n    tool_tilt_deg: 3.9\n")), "");  // cone: up to 4
  std::string e = errorOf(scratch("    tool: pyramid\n    tool_apex_deg: 170\n    tool_tilt_deg: 3\n"));
  EXPECT_NE(e.find("test.yaml:12:20: 'defects[0].tool_tilt_deg': a tilt of 3 deg"), std::string::npos) << e;
  EXPECT_NE(e.find("expected at most 2.54 deg"), std::string::npos) << e;
  e = errorOf(scratch("    tool: pyramid\n    tool_apex_deg: {uniform: [100, 140]}\n"
                      "    tool_tilt_deg: {uniform: [0, 40]}\n"));
  EXPECT_NE(e.find("tilts up to 40 deg would put the pyramid's edges below its tip (tool_apex_deg up to 140)"),
            std::string::npos) << e;
  EXPECT_EQ(errorOf(scratch("    tool_apex_deg: 170\n    tool_tilt_deg: 30\n    profile_mm: [-0.1, 0, 0, -0.05, 0.1, 0]\n")),
            "");  // an explicit profile does not use the tool
  // pattern: path and path_mm go together; the points must make a path of the chosen curve.
  EXPECT_EQ(errorOf(scratch("    pattern: path\n    path_mm: [0, 0, 10, 0, 10, 5]\n")), "");
  EXPECT_EQ(errorOf(scratch("    pattern: path\n    curve: bezier\n    path_mm: [0, 0, 1, 1, 2, 1, 3, 0]\n")), "");
  e = errorOf(scratch("    pattern: path\n"));
  EXPECT_NE(e.find("test.yaml:10:14: 'defects[0].pattern': pattern path needs 'path_mm'"), std::string::npos) << e;
  e = errorOf(scratch("    path_mm: [0, 0, 10, 0]\n"));
  EXPECT_NE(e.find("test.yaml:10:14: 'defects[0].path_mm': only pattern path reads path_mm (the pattern is random)"),
            std::string::npos) << e;
  e = errorOf(scratch("    pattern: path\n    path_mm: [0, 0, 10, 0, 10]\n"));
  EXPECT_NE(e.find("test.yaml:11:14: 'defects[0].path_mm': expected pairs [u, v]"), std::string::npos) << e;
  e = errorOf(scratch("    pattern: path\n    curve: bezier\n    path_mm: [0, 0, 1, 1, 2, 1, 3, 0, 4, 4]\n"));
  EXPECT_NE(e.find("test.yaml:12:14: 'defects[0].path_mm': curve bezier expected 3k + 1 control points (4, 7, 10, ...), "
                   "found 5"), std::string::npos) << e;
  e = errorOf(scratch("    pattern: path\n    path_mm: [3, 4, 3, 4]\n"));
  EXPECT_NE(e.find("'defects[0].path_mm': expected at least two distinct points"), std::string::npos) << e;
  e = errorOf(scratch("    pattern: key\n    curve: bezier\n"));
  EXPECT_NE(e.find("test.yaml:11:12: 'defects[0].curve': only pattern path reads curve (the pattern is key)"),
            std::string::npos) << e;
  // Neither are the older fields a pattern does not read.
  e = errorOf(scratch("    pattern: key\n    length_mm: 40\n"));
  EXPECT_NE(e.find("test.yaml:11:16: 'defects[0].length_mm': only pattern random reads length_mm (the pattern is key)"),
            std::string::npos) << e;
  e = errorOf(scratch("    pattern: swirl\n    orientation_deg: 30\n"));
  EXPECT_NE(e.find("'defects[0].orientation_deg': only patterns random and path read orientation_deg (the pattern is "
                   "swirl)"), std::string::npos) << e;
  e = errorOf(scratch("    pattern: key\n    center: [0.5, 0.5]\n"));
  EXPECT_NE(e.find("'defects[0].center': only patterns random, swirl and path read center (the pattern is key)"),
            std::string::npos) << e;
  EXPECT_EQ(errorOf(scratch("    pattern: swirl\n    center: [0.5, 0.5]\n")), "");
  EXPECT_EQ(errorOf(scratch("    length_mm: 40\n    curvature_per_mm: 0.1\n    orientation_deg: 10\n")), "");
  e = errorOf(scratch("    pattern: path\n    curve: spline\n    path_mm: [0, 0, 10, 0]\n"));
  EXPECT_NE(e.find("'defects[0].curve'"), std::string::npos) << e;
}

// render.geometry_cell_mm: read by the explicit-geometry reference only, 0 (automatic) or at least
// the 0.5 micrometres the automatic cell stops at; each refusal names the place.
TEST(Config, TheReferencesCellIsCheckedWhereItIsGiven) {
  auto with = [](const std::string& render) { return std::string(kMinimal) + "render: {" + render + "}\n"; };
  EXPECT_EQ(errorOf(with("scratches: geometry, geometry_cell_mm: 0.002")), "");
  EXPECT_EQ(errorOf(with("scratches: geometry, geometry_cell_mm: 0")), "");
  EXPECT_EQ(errorOf(with("scratches: groove")), "");  // the default (0) is not "given"
  std::string e = errorOf(with("scratches: groove, geometry_cell_mm: 0.002"));
  EXPECT_NE(e.find("test.yaml:8:47: 'render.geometry_cell_mm': only scratches: geometry reads geometry_cell_mm "
                   "(render.scratches is groove)"),
            std::string::npos)
      << e;
  e = errorOf(with("scratches: geometry, geometry_cell_mm: 0.0001"));
  EXPECT_NE(e.find("test.yaml:8:49: 'render.geometry_cell_mm': expected 0 (automatic) or at least 0.0005 mm, "
                   "found 0.0001"),
            std::string::npos)
      << e;
  e = errorOf(with("scratches: geometry, geometry_cell_mm: 2"));
  EXPECT_NE(e.find("'render.geometry_cell_mm': 2 is out of range; expected a value in [0, 1] mm"), std::string::npos)
      << e;
  e = errorOf(with("scratches: geometry, geometry_cell_mm: {uniform: [0.001, 0.002]}"));
  EXPECT_NE(e.find("'render.geometry_cell_mm'"), std::string::npos) << e;
}

TEST(Config, DistributionsSampleInRangeAndAreRecorded) {
  std::string y = std::string(kMinimal) +
                  "material:\n  type: car_paint\n  flake_amount: {normal: {mean: 0.5, std: 2}}\n"
                  "  clear_coat_roughness: {loguniform: [0.02, 0.5]}\n"
                  "defects:\n  - type: dent\n    count: {uniform: [2, 4]}\n"
                  "    radius_mm: {choice: [5, 10, 20], weights: [1, 0, 3]}\n";
  Config c = parseConfig(y, "t.yaml");
  Rng rng(42, Stream::Test);
  std::map<int, int> counts, radii;
  double lo = 1e9, hi = -1e9;
  for (int i = 0; i < 4000; ++i) {
    nlohmann::json rec;
    counts[int(sampleNumber(c.root["defects"].items[0]["count"], rng, rec))]++;
    radii[int(sampleNumber(c.root["defects"].items[0]["radius_mm"], rng, rec))]++;
    double f = sampleNumber(c.root["material"]["flake_amount"], rng, rec);
    EXPECT_GE(f, 0.0);  // clamped to the field's range [0, 1]
    EXPECT_LE(f, 1.0);
    double r = sampleNumber(c.root["material"]["clear_coat_roughness"], rng, rec);
    lo = std::min(lo, r);
    hi = std::max(hi, r);
    ASSERT_TRUE(rec.contains("defects[0].count"));
    ASSERT_TRUE(rec.contains("material.flake_amount"));
  }
  EXPECT_EQ(counts.size(), 3u);  // 2, 3 and 4 all occur
  for (auto& kv : counts) EXPECT_NEAR(kv.second / 4000.0, 1.0 / 3.0, 0.04) << kv.first;
  EXPECT_EQ(radii.count(10), 0u);  // weight 0
  EXPECT_NEAR(radii[20] / 4000.0, 0.75, 0.03);
  EXPECT_GE(lo, 0.02);
  EXPECT_LE(hi, 0.5);
  EXPECT_LT(lo, 0.03);
  EXPECT_GT(hi, 0.4);
  // Bad distributions are reported.
  EXPECT_NE(errorOf(std::string(kMinimal) + "render:\n  exposure_stops: {unifrom: [0, 1]}\n").find("did you mean 'uniform'"),
            std::string::npos);
  EXPECT_NE(errorOf(std::string(kMinimal) + "render:\n  exposure_stops: {uniform: [2, 1]}\n").find("min <= max"),
            std::string::npos);
}

TEST(Config, SameSeedSameDraws) {
  std::string y = std::string(kMinimal) + "render:\n  exposure_stops: {uniform: [-1, 1]}\n";
  Config c = parseConfig(y, "t.yaml");
  Rng a(5, Stream::Scene, 3), b(5, Stream::Scene, 3), d(5, Stream::Scene, 4);
  nlohmann::json r;
  double x = sampleNumber(c.root["render"]["exposure_stops"], a, r);
  EXPECT_EQ(x, sampleNumber(c.root["render"]["exposure_stops"], b, r));
  EXPECT_NE(x, sampleNumber(c.root["render"]["exposure_stops"], d, r));
}

TEST(Config, ReferenceDocIsUpToDate) {
  std::string path = std::string(DG_SOURCE_DIR) + "/docs/config.md";
  ASSERT_TRUE(std::filesystem::exists(path)) << "run: build/defectgen config-reference > docs/config.md";
  EXPECT_EQ(readTextFile(path), configReferenceMarkdown())
      << "docs/config.md is stale; run: build/defectgen config-reference > docs/config.md";
}

TEST(Config, EveryShippedConfigValidates) {
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(std::string(DG_SOURCE_DIR) + "/configs")) {
    if (e.path().extension() != ".yaml") continue;
    EXPECT_NO_THROW(loadConfig(e.path().string())) << e.path();
    ++n;
  }
  EXPECT_GE(n, 1);
}

TEST(Config, EditDistance) {
  EXPECT_EQ(editDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(editDistance("", "abc"), 3u);
  EXPECT_EQ(editDistance("same", "same"), 0u);
}

TEST(Config, CollectingModeReportsEveryError) {
  std::string y = "part:\n  type: plate\n  widht_mm: 300\nlights:\n  - type: dome\n    radiance: [1, 1]\n"
                  "camera:\n  fov_deg: 400\n  position: [0, 0, 500]\nrender:\n  spp: -1\n";
  std::vector<InputError> errors;
  parseConfig(y, "multi.yaml", &errors);
  ASSERT_EQ(errors.size(), 4u);
  EXPECT_NE(std::string(errors[0].what()).find("multi.yaml:3:3: unknown key 'widht_mm'"), std::string::npos) << errors[0].what();
  EXPECT_NE(std::string(errors[1].what()).find("multi.yaml:6:15"), std::string::npos) << errors[1].what();
  EXPECT_NE(std::string(errors[2].what()).find("'camera.fov_deg'"), std::string::npos) << errors[2].what();
  EXPECT_NE(std::string(errors[3].what()).find("'render.spp'"), std::string::npos) << errors[3].what();
  // The throwing variant stops at the first.
  try {
    parseConfig(y, "multi.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), std::string(errors[0].what()));
  }
}

TEST(Config, GltfDefaultsToMetres) {
  std::string dir = std::string(DG_SOURCE_DIR) + "/tests/fixtures/meshes/";
  auto cfg = [&](const std::string& mesh, const std::string& extra) {
    return "part:\n  type: mesh\n  path: " + dir + mesh + "\n" + extra +
           "lights:\n  - type: dome\ncamera:\n  fov_deg: 40\n  position: [0, 0, 500]\n";
  };
  EXPECT_DOUBLE_EQ(parseConfig(cfg("quad_uv.gltf", ""), "t.yaml").root["part"]["unit_scale_to_mm"].num(), 1000.0);
  EXPECT_DOUBLE_EQ(parseConfig(cfg("quad_uv.gltf", "  unit_scale_to_mm: 10\n"), "t.yaml")
                       .root["part"]["unit_scale_to_mm"].num(), 10.0);
  EXPECT_DOUBLE_EQ(parseConfig(cfg("quad_vt.obj", ""), "t.yaml").root["part"]["unit_scale_to_mm"].num(), 1.0);
}
