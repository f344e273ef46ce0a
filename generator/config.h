// The config: one schema describes every field (type, unit, default, range, documentation). The
// same schema drives parsing and validation (errors with file:line:column), `defectgen validate`'s
// printout of the resolved config, and docs/config.md, so the three cannot drift apart.
//
// Any number whose field allows it may be a distribution instead of a constant:
//   {uniform: [a, b]}  {loguniform: [a, b]}  {normal: {mean: m, std: s, min: lo, max: hi}}
//   {choice: [x, y, z], weights: [1, 2, 1]}
// Distributions are sampled per dataset sample; every sampled value is recorded in the sample's
// metadata under its config path.
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/rng.h"

namespace dg {

enum class FieldType { Number, Integer, Bool, String, Enum, Path, Vector, Object, List };

struct Field {
  std::string key;
  FieldType type = FieldType::Number;
  std::string unit;  // "mm", "deg", "" ...
  std::string doc;
  bool required = false;
  bool random_ok = false;  // may be a distribution
  std::optional<double> min, max;
  bool min_exclusive = false;
  std::vector<std::string> enum_values;
  nlohmann::json default_value;  // null = no default
  int vector_size = 0;           // for Vector
  FieldType element_type = FieldType::Number;  // for Vector
  // For Object and List-of-Object: the fields. When `variants` is not empty, the object has a
  // required `type` enum whose value selects the extra fields.
  std::vector<Field> fields;
  std::map<std::string, std::vector<Field>> variants;
  std::map<std::string, std::string> variant_docs;
};

const Field& configSchema();

// A resolved value: a constant or a distribution, with where it came from.
struct Dist {
  enum class Kind { Const, Uniform, LogUniform, Normal, Choice };
  Kind kind = Kind::Const;
  double a = 0, b = 0;          // uniform/loguniform bounds; normal mean/std
  double lo = 0, hi = 0;        // normal clamping
  std::vector<nlohmann::json> choices;
  std::vector<double> weights;
  nlohmann::json constant;
};

struct Value {
  const Field* field = nullptr;
  std::string path;  // "defects[0].radius_mm"
  int line = 0, column = 0;
  bool defaulted = false;
  Dist dist;  // scalars
  std::vector<Value> items;                 // Vector and List
  std::map<std::string, Value> members;     // Object
  std::vector<std::string> member_order;    // keys in schema order

  bool has(const std::string& k) const { return members.count(k) != 0; }
  const Value& operator[](const std::string& k) const;
  bool isConstant() const { return dist.kind == Dist::Kind::Const; }
  // Constant accessors (throw std::logic_error if the value is a distribution).
  double num() const;
  std::string str() const;
  bool flag() const;
};

struct Config {
  std::string file;   // path of the YAML file
  std::string text;   // its bytes (hashed into the manifest)
  Value root;
  std::string hash() const;  // hex digest of the resolved config
  // The same without `count`: what each sample's bytes depend on besides the seed and its index,
  // so a dataset can be grown (generate --resume with a larger --count).
  std::string sceneHash() const;
};

// Loads and validates a config. Throws InputError with file:line:column for every problem.
Config loadConfig(const std::string& path);
Config parseConfig(const std::string& text, const std::string& file_name);
// Collecting variant for `defectgen validate`: every field error is appended to `errors` (in file
// order) instead of stopping at the first; the returned config is only usable when none occurred.
// Malformed YAML still throws, since nothing after the syntax error can be read.
Config parseConfig(const std::string& text, const std::string& file_name, std::vector<InputError>* errors);
Config loadConfigAllErrors(const std::string& path, std::vector<InputError>& errors);

// Samples a scalar value (number or string) and records it in `record` under its path when it was
// a distribution.
nlohmann::json sampleValue(const Value& v, Rng& rng, nlohmann::json& record);
double sampleNumber(const Value& v, Rng& rng, nlohmann::json& record);

// Human-readable resolved config: every field with its value, unit and whether it was defaulted.
std::string describeConfig(const Config& c);
// docs/config.md, generated from the schema.
std::string configReferenceMarkdown();

// Levenshtein distance, for "did you mean" suggestions.
size_t editDistance(const std::string& a, const std::string& b);

}  // namespace dg
