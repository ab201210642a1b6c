// Setting declarations: the checks a front end applies where a value enters, their words, and
// the documents printed from a list (common/setting_declaration.hpp, setting_documents.hpp).
#include "magnetometer_insitu_calibration/common/setting_declaration.hpp"
#include "magnetometer_insitu_calibration/common/setting_documents.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace mic = magnetometer_insitu_calibration;

TEST(SettingDeclaration, ANumberOutsideItsRangeIsRefusedInItsUnit) {
  const mic::SettingDeclaration d = mic::number_setting("huber_k", "huber_k", "--huber-k", "sigmas", 2.0, mic::above(0), "h");
  EXPECT_EQ(d.problem(2.5), "");
  EXPECT_EQ(d.problem(0.0), "must be > 0 sigmas, not 0");
  EXPECT_EQ(d.problem(std::string("x")), "must be a number");
  EXPECT_EQ(d.problem(static_cast<long long>(3)), "");  // an integer is a number
  const mic::SettingDeclaration g = mic::number_setting("gamma", "gamma", "--gamma", "-", 1.0, mic::between(0, 4), "g");
  EXPECT_EQ(g.problem(4.0), "");
  EXPECT_EQ(g.problem(4.5), "must be in [0, 4], not 4.5");
  const mic::SettingDeclaration c =
      mic::number_setting("c", "c", "", "-", 0.5, mic::SettingRange{0, 1, false, true}, "coherence");
  EXPECT_EQ(c.problem(1.0), "must be in [0, 1), not 1");
  EXPECT_EQ(c.problem(0.0), "");
}

TEST(SettingDeclaration, IntegersChoicesAndTexts) {
  const mic::SettingDeclaration i = mic::integer_setting("iterations", "iterations", "--iterations", "-", 8,
                                                         mic::between(1, 100), "n");
  EXPECT_EQ(i.problem(static_cast<long long>(0)), "must be in [1, 100], not 0");
  EXPECT_EQ(i.problem(2.5), "must be a whole number");
  const mic::SettingDeclaration m = mic::choice_setting("method", "method", "--method", {"robust", "plain"}, "robust", "m");
  EXPECT_EQ(m.problem(std::string("plain")), "");
  EXPECT_EQ(m.problem(std::string("fast")), "expected robust or plain, got 'fast'");
  const mic::SettingDeclaration none_ok = mic::text_setting(mic::SettingKind::kTopic, "t", "t", "", "", "topic or none");
  EXPECT_EQ(none_ok.problem(std::string()), "");
  const mic::SettingDeclaration named = mic::text_setting(mic::SettingKind::kTopic, "o", "o", "", "corrected", "out");
  EXPECT_EQ(named.problem(std::string()), "must not be empty");  // its default is a name: no "none"
}

TEST(SettingDeclaration, ParsesCommandLineTextByKind) {
  const mic::SettingDeclaration d = mic::number_setting("k", "", "--k", "s", 1.0, mic::above(0), "k");
  EXPECT_EQ(std::get<double>(d.parse("0.25")), 0.25);
  EXPECT_THROW(d.parse("0.25s"), std::invalid_argument);
  EXPECT_THROW(d.parse(""), std::invalid_argument);
  const mic::SettingDeclaration i = mic::integer_setting("n", "", "--n", "-", 1, mic::at_least(1), "n");
  EXPECT_EQ(std::get<long long>(i.parse("12")), 12);
  EXPECT_THROW(i.parse("1.5"), std::invalid_argument);
}

TEST(SettingDocuments, YamlSetsPlainDefaultsAndShowsTheOthersCommented) {
  const mic::SettingDeclarations list = mic::setting_group(
      "Group", {mic::number_setting("window", "window", "--window", "s", 3600.0, mic::above(0), "window length"),
                mic::number_setting("p", "test_input_period", "", "s", 0.0, mic::above(0), "the tests' period")
                    .noted("input_period"),
                mic::text_setting(mic::SettingKind::kTopic, "r", "reference_topic", "", "", "the reference").made_required(),
                mic::text_setting(mic::SettingKind::kText, "cli_only", "", "--cli-only", "auto", "not a parameter")});
  EXPECT_EQ(mic::settings_yaml(list),
            "\n# --- Group\n"
            "window: 3600.0                    # [s, > 0] window length\n"
            "# test_input_period: input_period # [s, > 0] the tests' period\n"
            "# reference_topic: required       # [topic] the reference\n");
  EXPECT_EQ(mic::parameter_table(list),
            "| parameter | unit | default | range | meaning |\n|---|---|---|---|---|\n"
            "| `window` | s | 3600 | > 0 | window length |\n"
            "| `test_input_period` | s | input_period | > 0 | the tests' period |\n"
            "| `reference_topic` | topic | required |  | the reference |\n");
  EXPECT_EQ(mic::option_table(list),
            "| option | unit | default | range | meaning |\n|---|---|---|---|---|\n"
            "| `--window` | s | 3600 | > 0 | window length |\n"
            "| `--cli-only` | text | auto |  | not a parameter |\n");
}

TEST(SettingDocuments, ABlockIsFoundAndReplacedBetweenItsMarkers) {
  const std::string doc = "intro\n<!-- settings node -->\nold\n<!-- /settings -->\nend\n";
  EXPECT_EQ(mic::marked_block(doc, "node", mic::BlockStyle::kMarkdown), "old\n");
  EXPECT_EQ(mic::with_marked_block(doc, "node", mic::BlockStyle::kMarkdown, "new\n"),
            "intro\n<!-- settings node -->\nnew\n<!-- /settings -->\nend\n");
  EXPECT_THROW(mic::marked_block(doc, "other", mic::BlockStyle::kMarkdown), std::runtime_error);
  EXPECT_EQ(mic::marked_block("# <settings a>\nx: 1\n# </settings>\n", "a", mic::BlockStyle::kYaml), "x: 1\n");
}
