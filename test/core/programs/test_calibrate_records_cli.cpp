// calibrate_records as a user runs it: exit status, JSON document, and bad input named.
#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <random>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

namespace mic = magnetometer_insitu_calibration;

namespace {

using mic::test::ProgramRun;
using magnetometer_insitu_calibration::test::read_json;

ProgramRun run_cli(const std::string& args) { return mic::test::run_program(CALIBRATE_RECORDS_BIN, args); }

}  // namespace

// The fixture outside the anonymous namespace: its tests' classes are global, and this file is
// compiled in one translation unit with its concern's others (-Wsubobject-linkage).
class CalibrateRecordsCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = mic::test::make_temp_dir("cli");
    mic::SimulationSettings s;
    s.duration_s = 6 * 3600.0;
    s.keep_clean_field = false;
    pair_ = mic::simulate_pair(s);
    mic::write_csv_record(dir_ + "/ref.csv", pair_.reference);
    mic::write_csv_record(dir_ + "/test.csv", pair_.test);
  }
  static std::string dir_;
  static mic::SimulatedPair pair_;
};
std::string CalibrateRecordsCli::dir_;
mic::SimulatedPair CalibrateRecordsCli::pair_;

TEST_F(CalibrateRecordsCli, WritesTheJsonDocumentWithTheTruthInside) {
  const ProgramRun r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --intervals 2 --json " + dir_ +
                    "/out.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("scale ratio Kxt/Kxr"), std::string::npos);
  const nlohmann::json j = read_json(dir_ + "/out.json");
  ASSERT_EQ(j["windows"].size(), 3u);
  const auto& day = j["windows"][2];
  for (const char* key : {"window_start", "window_end", "samples", "harmonic_first", "matrix", "matrix_stderr", "matrix_covariance",
                          "trend_nT_per_day", "scale_ratio", "scale_ratio_ci95", "nonorthogonality_deg",
                          "nonorthogonality_ci95_deg", "misalignment_deg", "misalignment_ci95_deg",
                          "axis_deviation_deg", "condition_number", "coherence", "residual_rms_nT", "quality"}) {
    EXPECT_TRUE(day.contains(key)) << key;
  }
  for (int k = 0; k < 9; ++k) {
    const double value = day["matrix"][k / 3][k % 3], se = day["matrix_stderr"][k / 3][k % 3];
    EXPECT_LT(std::abs(value - pair_.n_true(k / 3, k % 3)), 3.0 * se) << k;
  }
  EXPECT_EQ(day["harmonic_first"], 5);   // ceil(0.0002 * 21600)
  EXPECT_EQ(day["harmonic_last"], 216);  // floor(0.01 * 21600)
}

TEST_F(CalibrateRecordsCli, MissingFileIsNamed) {
  const ProgramRun r = run_cli("--reference " + dir_ + "/nope.sec --test " + dir_ + "/test.csv");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("nope.sec"), std::string::npos) << r.output;
}

TEST_F(CalibrateRecordsCli, MalformedLineIsNamedWithItsNumber) {
  {
    std::ofstream bad(dir_ + "/bad.csv");
    bad << "time,x,y,z\n1747180800,1,2,3\n1747180801,1,2,3\n1747180802,1,two,3\n";
  }
  const ProgramRun r = run_cli("--reference " + dir_ + "/bad.csv --test " + dir_ + "/test.csv");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("bad.csv:4"), std::string::npos) << r.output;
}

TEST_F(CalibrateRecordsCli, RecordsThatDoNotOverlapAreRejected) {
  {
    std::ofstream later(dir_ + "/later.csv");
    later << "time,x,y,z\n";
    for (int i = 0; i < 100; ++i) later << 1800000000 + i << ",1,2,3\n";
  }
  const ProgramRun r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/later.csv");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("overlap"), std::string::npos) << r.output;
}

TEST_F(CalibrateRecordsCli, RecordOfNaNIsRejected) {
  {
    std::ofstream nan(dir_ + "/nan.csv");
    nan << "time,x,y,z\n";
    for (int i = 0; i < 3600; ++i) nan << 1747180800 + i << ",nan,nan,nan\n";
  }
  const ProgramRun r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/nan.csv");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("nan.csv: no sample has three finite components"), std::string::npos) << r.output;
}

TEST_F(CalibrateRecordsCli, EmptyBandAndBadOptionsAreNamed) {
  ProgramRun r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --band 0.01:0.001");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("band"), std::string::npos) << r.output;
  r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --band 1e-3");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--band"), std::string::npos) << r.output;
  r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --window 3600 --step 7200");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("step"), std::string::npos) << r.output;
  // Each declared option is checked against its declaration where it enters, in the user's words.
  r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --temperature-max-gap 0");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("calibrate_records: --temperature-max-gap: must be > 0 s, not 0"), std::string::npos) << r.output;
  r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --method fast");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("calibrate_records: --method: expected robust or plain, got 'fast'"), std::string::npos)
      << r.output;
}

// Errors of the core's settings name the option the user gave, not the settings field; what
// could only fail at the end (the JSON's directory) or gives nothing to calibrate (one file as
// both instruments, windows too short for the band) is refused before any work.
TEST_F(CalibrateRecordsCli, BadOptionsAreNamedByTheirOptionBeforeAnyWork) {
  const std::string io = "--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {io + "--tolerance -1", "calibrate_records: --tolerance: must be"},
      {io + "--output-period 0", "calibrate_records: --output-period: must be"},
      {io + "--max-fill -3", "calibrate_records: --max-fill: must be"},
      {io + "--huber-k -1", "calibrate_records: --huber-k: must be"},
      {io + "--window 100 --step 100", "calibrate_records: --window: of 100 s holds only 1 DFT harmonics in the band"},
      // Decimated to minutes, the records' Nyquist frequency (0.0083 Hz) is under the default band's top.
      {io + "--output-period 60", "calibrate_records: --band: the band's top 0.01 Hz is above the Nyquist frequency 0.00833333 Hz"},
      {io + "--window 1e9 --step 3600", "calibrate_records: --window: of 1e+09 s is longer than the record (21600 s)"},
      {io + "--json " + dir_ + "/no_such_dir/out.json", "calibrate_records: --json: cannot write"},
      {"--reference " + dir_ + "/ref.csv --test " + dir_ + "/../" + dir_.substr(dir_.rfind('/') + 1) + "/ref.csv",
       "is also given as --reference"},
  };
  for (const auto& [args, expected] : cases) {
    SCOPED_TRACE(args);
    const ProgramRun r = run_cli(args);
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("Summary of"), std::string::npos) << "refused only after calibrating:\n" << r.output;
  }
}

// --intervals K makes windows of the record's length / K: the band's harmonics rule of --window
// refuses them when too short, naming --intervals, the interval's length and the most intervals
// the record allows (6 h, default band: 1735 s windows hold 16 harmonics, 12 intervals). K = 0 is
// no layout: refused, saying how to ask for the whole record.
TEST_F(CalibrateRecordsCli, IntervalsTooShortForTheBandOrZeroAreRefused) {
  const std::string io = "--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv ";
  ProgramRun r = run_cli(io + "--intervals 1000");
  EXPECT_EQ(r.status, 1) << r.output;
  for (const char* expected : {"calibrate_records: --intervals: 1000 intervals of the 21600 s record: an interval of 21 s",
                               "holds only 0 DFT harmonics in the band 0.0002-0.01 Hz, fewer than the 16 a window needs",
                               "windows of 1735 s or longer hold them; at most 12 intervals"}) {
    EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
  }
  EXPECT_EQ(r.output.find("Summary of"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("nan"), std::string::npos) << r.output;
  r = run_cli(io + "--intervals 0");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("calibrate_records: --intervals: must be >= 1, not 0"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("Summary of"), std::string::npos) << r.output;
}

// --help: the flags that are on by default do not read "{false}" (the value CLI11 shows for the
// negated form), and say they are on.
TEST_F(CalibrateRecordsCli, HelpSaysTheOnFlagsAreOn) {
  const ProgramRun r = run_cli("--help");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("{false}"), std::string::npos) << r.output;
  for (const char* flag : {"--screen,--no-screen", "--section-trend,--no-section-trend", "--pair-noise,--no-pair-noise",
                           "--response-model,--no-response-model"}) {
    const std::size_t at = r.output.find(flag);
    ASSERT_NE(at, std::string::npos) << flag;
    EXPECT_NE(r.output.substr(at, 400).find("on by default"), std::string::npos) << flag;
  }
}

// A window that fails its quality rules is not a calibration: its summary gives no verdicts and
// no correction to apply, its JSON no verdicts, and when every window fails the program says so
// and exits 3 (the report still written) so that a script does not take it for a calibration.
TEST_F(CalibrateRecordsCli, AFlaggedRecordGivesNoVerdictsNorCorrectionAndExits3) {
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  s.seed = 77;  // another field: the test does not follow the reference
  mic::write_csv_record(dir_ + "/unrelated.csv", mic::simulate_pair(s).test);
  const ProgramRun r = run_cli("--reference " + dir_ + "/ref.csv --test " + dir_ + "/unrelated.csv --json " + dir_ +
                               "/flagged.json");
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("quality low_coherence"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("A flagged window is not a calibration: no verdicts, no correction"), std::string::npos);
  EXPECT_EQ(r.output.find("Correction:"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("undecided"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("every window is flagged (see the report): no calibration to apply"), std::string::npos);
  const nlohmann::json j = read_json(dir_ + "/flagged.json");
  ASSERT_EQ(j["windows"].size(), 1u);
  EXPECT_EQ(j["windows"][0]["quality"], "low_coherence");
  EXPECT_TRUE(j["windows"][0]["verdicts"].empty()) << j["windows"][0]["verdicts"].dump();
}

// The errors-in-variables correction uses a reference noise model only: without a noise figure
// or a third instrument the reference's noise is identified from the pair above the band; with
// --no-pair-noise none is applied and every report says so; --reference-noise-pT gives the
// reference's figure. A share of the residual is never taken for reference noise: the old
// --eiv-ratio is refused.
TEST_F(CalibrateRecordsCli, ReportsTheNoiseModelOfTheErrorsInVariablesStep) {
  const std::string io = "--reference " + dir_ + "/ref.csv --test " + dir_ + "/test.csv --json " + dir_;
  struct Case {
    std::string options, json, expected;
  };
  const std::vector<Case> cases = {
      {"--no-pair-noise", "/eiv_default.json", "none (no reference noise model)"},
      {"--eiv none", "/eiv_none.json", "none (off)"},
      {"--reference-noise-pT 5", "/eiv_given.json",
       "reference noise from the maker's figure: white 0/0/0 pT rms, 1/f 5/5/5 pT/sqrt(Hz) at 1 Hz (x/y/z)"},
      {"--method plain", "/eiv_plain.json", "none (plain Eq. 2)"},
  };
  for (const Case& c : cases) {
    const ProgramRun r = run_cli(io + c.json + " " + c.options);
    ASSERT_EQ(r.status, 0) << c.options << ": " << r.output;
    EXPECT_NE(r.output.find("EIV: " + c.expected + "\n"), std::string::npos) << c.options << ": " << r.output;
    const nlohmann::json j = read_json(dir_ + c.json);
    EXPECT_EQ(j["windows"][0]["eiv"], c.expected) << c.options;
  }
  // The default: the pair's noise, said in the EIV line, the JSON and the window's own line
  // (its n against the simulated truth: WritesTheJsonDocumentWithTheTruthInside runs the default).
  const ProgramRun pair = run_cli(io + "/eiv_pair.json");
  ASSERT_EQ(pair.status, 0) << pair.output;
  EXPECT_NE(pair.output.find("EIV: reference noise from the pair above the band: white "), std::string::npos) << pair.output;
  EXPECT_NE(pair.output.find("whole record: reference noise from the pair above the band (0.03-0.25 Hz"), std::string::npos)
      << pair.output;
  {
    const nlohmann::json j = read_json(dir_ + "/eiv_pair.json");
    EXPECT_NE(j["windows"][0]["eiv"].get<std::string>().find("from the pair above the band"), std::string::npos);
    EXPECT_EQ(j["windows"][0]["eiv_applied"], "applied");
    EXPECT_EQ(j["windows"][0]["reference_noise_source"], "pair above the band");
    EXPECT_NE(j["windows"][0]["reference_noise"].get<std::string>().find("1/f"), std::string::npos);
  }
  const ProgramRun bad = run_cli(io + "/x.json --eiv none --reference-noise-pT 5");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("--reference-noise-pT"), std::string::npos) << bad.output;
  const ProgramRun negative = run_cli(io + "/x.json --reference-noise-pT -1");
  EXPECT_NE(negative.status, 0);
  EXPECT_NE(negative.output.find("--reference-noise-pT"), std::string::npos) << negative.output;
  for (const std::string ratio : {"--eiv-ratio 0.03", "--eiv ratio"}) {
    const ProgramRun refused = run_cli(io + "/x.json " + ratio);
    EXPECT_NE(refused.status, 0) << ratio;
    EXPECT_NE(refused.output.find("--eiv"), std::string::npos) << ratio << ": " << refused.output;
  }
}

// --third identifies the reference's noise by the three-cornered hat in each window and gives it
// to the errors-in-variables correction; every report says where the noise model came from.
TEST_F(CalibrateRecordsCli, ThirdInstrumentIdentifiesTheReferenceNoise) {
  mic::SimulationSettings s;
  s.duration_s = 6 * 3600.0;
  s.seed = 5;
  s.reference_white_nT = 0.3;  // a noisy reference: 30x the test
  s.keep_clean_field = true;
  const mic::SimulatedPair p = mic::simulate_pair(s);
  mic::VectorRecord third = p.test;  // a second instrument: the field, its own white noise
  third.values_nT = p.field_nT;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.03);  // nT, white
  for (Eigen::Index i = 0; i < third.values_nT.rows(); ++i) {
    for (int c = 0; c < 3; ++c) third.values_nT(i, c) += noise(rng);
  }
  mic::write_csv_record(dir_ + "/hat_ref.csv", p.reference);
  mic::write_csv_record(dir_ + "/hat_test.csv", p.test);
  mic::write_csv_record(dir_ + "/hat_third.csv", third);
  const std::string io = "--reference " + dir_ + "/hat_ref.csv --test " + dir_ + "/hat_test.csv ";
  const ProgramRun r = run_cli(io + "--third " + dir_ + "/hat_third.csv --json " + dir_ + "/hat.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("reference noise from the three-cornered hat"), std::string::npos) << r.output;
  const nlohmann::json j = read_json(dir_ + "/hat.json");
  const std::string eiv = j["windows"][0]["eiv"];
  EXPECT_EQ(eiv.rfind("reference noise from the three-cornered hat with --third: white ", 0), 0u) << eiv;
  EXPECT_EQ(j["windows"][0]["reference_noise_source"], "three-cornered hat");
  // Against the simulated truth: the white level the correction used (the x axis's, as the
  // report prints it first) within 20 % of the reference's simulated 300 pT rms.
  const std::size_t at = eiv.find("white ");
  ASSERT_NE(at, std::string::npos) << eiv;
  EXPECT_NEAR(std::stod(eiv.substr(at + 6)), 300.0, 60.0) << eiv;

  const ProgramRun off = run_cli(io + "--third " + dir_ + "/hat_third.csv --eiv none");
  EXPECT_NE(off.status, 0);
  EXPECT_NE(off.output.find("--third"), std::string::npos) << off.output;
  const ProgramRun both = run_cli(io + "--third " + dir_ + "/hat_third.csv --reference-noise-pT 5");
  EXPECT_NE(both.status, 0);
  EXPECT_NE(both.output.find("--third"), std::string::npos) << both.output;
  const ProgramRun missing = run_cli(io + "--third " + dir_ + "/no_such.csv");
  EXPECT_NE(missing.status, 0);
  EXPECT_NE(missing.output.find("no_such.csv"), std::string::npos) << missing.output;
}
