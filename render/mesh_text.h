// The text of mesh files: numbers and tokens with their columns (the OBJ parser's), and, after a
// reader has failed on an OFF, STL, PLY or binary glTF file, where and why. CGAL's readers (render/mesh_io.cpp)
// only say that they failed; these find the first line and column that break the format, and say
// what was expected there. Kept out of mesh_io.cpp, the one translation unit that includes CGAL.
#pragma once
#include <array>
#include <cstdint>
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
// ASCII OFF file (a face's corner count; and the header's vertex and face counts, at 6 and 8
// bytes each at least) or a PLY file, ASCII or binary (any list property's length). CGAL's readers
// size an array from such a number before they read its entries, so one bad count in a 5 KB file
// had them allocate and fill 12 to 17 GB for up to a minute before they failed (scripts/fuzz-meshes
// seed 104 under AddressSanitizer). A pass over the file, before CGAL reads it; nullopt where
// every length fits (or where the file is not in a form it reads: CGAL and the diagnosers above
// report those). Binary OFF is readBinaryOff's.
std::optional<FileProblem> oversizedOff(const std::string& path);
std::optional<FileProblem> oversizedPlyList(const std::string& path);
// A binary OFF file: Geomview's "OFF BINARY" (the keyword, the word BINARY, and from the byte
// after the next newline big-endian 32-bit integers and floats: the vertex, face and edge counts,
// each vertex's x y z [nx ny nz] [s t] after the keyword's N and ST, each face's corner count, its
// corners, and a colour of 0 to 4 floats after its count). Read here, not by CGAL: CGAL 5.5's
// polygon-soup reader does not skip a face's colour count, so it reads every face after the first
// from the wrong bytes (a two-triangle quad came back as one triangle and an empty face), and it
// sizes a face from its count before reading it. `binary` false: the file is not binary OFF (CGAL
// reads it). A problem names the element and its byte offset: counts the file cannot hold, a face
// of fewer than 3 corners, a corner that is not a declared vertex, a coordinate that is not
// finite, a colour count outside 0 to 4, a file that ends early. The keywords whose binary
// layout readers disagree on (C: 3 or 4 floats a colour) or that need more than 3 dimensions
// (4, n) are refused by name.
struct OffMesh {
  std::vector<std::array<double, 3>> pos, nrm;  // nrm: empty, or one per vertex
  std::vector<std::array<double, 2>> uv;        // empty, or one per vertex
  std::vector<std::vector<uint32_t>> faces;
};
struct BinaryOff {
  bool binary = false;
  std::optional<FileProblem> problem;
  OffMesh mesh;
};
BinaryOff readBinaryOff(const std::string& path);
// A binary glTF's header and first chunk (magic, version 2, the declared length against the
// file's, a JSON chunk that fits), which assimp reports only as "no suitable reader".
std::optional<FileProblem> diagnoseGlb(const std::string& path);
// A glTF's JSON (the .gltf file, or a .glb's JSON chunk) that does not parse, with the line and
// column of a .gltf file, which assimp also reports only as "no suitable reader".
std::optional<FileProblem> diagnoseGltfJson(const std::string& path);

}  // namespace dg::meshtext
