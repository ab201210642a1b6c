// The tolerance file (formats/tolerance_file.hpp): values read as written, defaults kept for
// keys left out, and every bad value refused with the file and the key named.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/tolerance_file.hpp"

#include <gtest/gtest.h>

#include <string>

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The InputError's where() of parsing `text` as file "tol.yaml"; "" when it parses.
std::string refusal(const std::string& text) {
  try {
    mic::parse_tolerances(text, "tol.yaml");
  } catch (const mic::InputError& e) {
    return e.where();
  }
  return "";
}

}  // namespace

TEST(ToleranceFile, ReadsOneValueOrThreeAndKeepsTheDefaultsOfKeysLeftOut) {
  const mic::Tolerances t =
      mic::parse_tolerances("scale_percent: 0.04\nnonorthogonality_deg: [0.02, 0.03, 0.05]\n", "lab.yaml");
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(t.scale(i), 0.0004);
  EXPECT_DOUBLE_EQ(t.nonorthogonality_deg(0), 0.02);
  EXPECT_DOUBLE_EQ(t.nonorthogonality_deg(1), 0.03);
  EXPECT_DOUBLE_EQ(t.nonorthogonality_deg(2), 0.05);
  // 2 mrad, INTERMAGNET's orthogonality, for the misalignment left out.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(t.misalignment_deg(i), 0.11459, 1e-5);
  // The report's "Tolerances:" line says which are the file's.
  EXPECT_EQ(t.source, "lab.yaml; misalignment_deg not in it: INTERMAGNET's 1-second standard");
  EXPECT_EQ(mic::parse_tolerances("scale_percent: 0.04\nnonorthogonality_deg: 0.02\nmisalignment_deg: 0.02\n",
                                  "lab.yaml")
                .source,
            "lab.yaml");
  const mic::Tolerances scale_only = mic::parse_tolerances("scale_percent: 0.5\n", "scale.yaml");
  EXPECT_EQ(scale_only.source,
            "scale.yaml; nonorthogonality_deg, misalignment_deg not in it: INTERMAGNET's 1-second standard");
}

TEST(ToleranceFile, RefusesBadValuesNamingTheFileAndTheKey) {
  EXPECT_EQ(refusal("scale_percent: -1\n"), "tol.yaml: scale_percent");
  EXPECT_EQ(refusal("scale_percent: 0\n"), "tol.yaml: scale_percent");
  EXPECT_EQ(refusal("misalignment_deg: [0.1, 0.2]\n"), "tol.yaml: misalignment_deg");
  EXPECT_EQ(refusal("nonorthogonality_deg: two\n"), "tol.yaml: nonorthogonality_deg");
  EXPECT_EQ(refusal("nonorthogonality_deg: .nan\n"), "tol.yaml: nonorthogonality_deg");
  EXPECT_EQ(refusal("scale: 1\n"), "tol.yaml: scale");  // unknown key (scale_percent is the key)
  EXPECT_EQ(refusal("- 1\n- 2\n"), "tol.yaml");
  EXPECT_EQ(refusal(""), "tol.yaml");  // empty: no tolerance of its own, yet named in the report
  EXPECT_EQ(refusal("# only a comment\n"), "tol.yaml");
  EXPECT_EQ(refusal("scale_percent: [1, 2\n").rfind("tol.yaml:", 0), 0u);  // not YAML: file and line
  EXPECT_THROW(mic::read_tolerance_file("/nonexistent/tolerances.yaml"), mic::InputError);
}

// YAML allows a key once; yaml-cpp reads a repeated one and the later would win unseen: the file
// is refused, naming the file, the line of the repeat, the key and the line of its first use.
TEST(ToleranceFile, RefusesAKeyGivenTwiceNamingFileLineAndKey) {
  try {
    mic::parse_tolerances("scale_percent: 0.04\nmisalignment_deg: 0.02\nscale_percent: 0.5\n", "tol.yaml");
    ADD_FAILURE() << "a repeated key was read";
  } catch (const mic::InputError& e) {
    EXPECT_STREQ(e.what(), "tol.yaml:3: key 'scale_percent' given twice (first on line 1)");
  }
}
