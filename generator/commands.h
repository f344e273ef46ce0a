// Subcommands implemented outside main.cpp.
#pragma once

namespace CLI {
class App;
}

namespace dg {

// `defectgen compare REFERENCE TEST ...` (see docs/compare.md).
void addCompareCommand(CLI::App& app);

}  // namespace dg

namespace dg {

// `defectgen contact-sheet DATASET [--out PNG] [--columns N] [--thumb PX]`: a grid of the dataset's
// images with the masks overlaid (class colour, instance outlines).
void addContactSheetCommand(CLI::App& app);

}  // namespace dg
