// The text of mesh files: numbers and tokens with their columns (the OBJ parser's), and, after a
// reader has failed on an OFF, STL, PLY or binary glTF file, where and why. CGAL's readers (render/mesh_io.cpp)
// only say that they failed; these find the first line and column that break the format, and say
// what was expected there. Kept out of mesh_io.cpp, the one translation unit that includes CGAL.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace dg::meshtext {

// A whole token as a double, locale-independently. Accepts a leading '+', "nan", "inf"; an
// out-of-range literal gives +-inf (overflow) or a tiny value (underflow), as strtod would.
bool parseDouble(std::string_view tok, double& out);
// A whole token as an integer.
bool parseLong(std::string_view tok, long& out);

// Whitespace-separated tokens of a line, with their 1-based columns.
struct Token {
  std::string_view text;
  int column;
};
std::vector<Token> tokenize(std::string_view line);

// Where a file breaks its format: 1-based line and column (0: no position), and what was expected.
struct FileProblem {
  int line = 0, column = 0;
  std::string what;
};

// A number that parses but is not finite (nan, inf, 1e999), which CGAL's stream readers reject
// without saying why.
std::optional<FileProblem> findNonFinite(const std::string& path);

// The first fault in an ASCII OFF file (header, counts, vertex lines, face lines: corner counts of
// at least 3 and indices of declared vertices), an STL file (a binary one's size against its
// facet count; an ASCII one's keywords and numbers) or a PLY file (the header; an ASCII body's
// lines against it, vertex coordinates finite, face indices in range). nullopt where none is
// found (binary OFF, nOFF and 4OFF are not looked into).
std::optional<FileProblem> diagnoseOff(const std::string& path);
std::optional<FileProblem> diagnoseStl(const std::string& path);
std::optional<FileProblem> diagnosePly(const std::string& path);
// A face or list whose declared length the rest of the file cannot hold (or a negative one), in an
// ASCII OFF file (a face's corner count) or a PLY file, ASCII or binary (any list property's
// length). CGAL's readers size an array from that number before they read its entries, so one
// bad count in a 5 KB file had them allocate and fill 12 to 17 GB for up to a minute before they
// failed (scripts/fuzz-meshes seed 104 under AddressSanitizer). A pass over the file, before
// CGAL reads it; nullopt where every length fits (or where the file is not in a form it reads:
// CGAL and the diagnosers above report those). Binary OFF is not looked into.
std::optional<FileProblem> oversizedOffFace(const std::string& path);
std::optional<FileProblem> oversizedPlyList(const std::string& path);
// A binary glTF's header and first chunk (magic, version 2, the declared length against the
// file's, a JSON chunk that fits), which assimp reports only as "no suitable reader".
std::optional<FileProblem> diagnoseGlb(const std::string& path);
// A glTF's JSON (the .gltf file, or a .glb's JSON chunk) that does not parse, with the line and
// column of a .gltf file, which assimp also reports only as "no suitable reader".
std::optional<FileProblem> diagnoseGltfJson(const std::string& path);

}  // namespace dg::meshtext
