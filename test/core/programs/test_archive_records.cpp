// Archived records (src/tools/archive_records.hpp): LEMI formats recognised and dispatched by
// read_record, damaged text lines reported with their numbers and skipped without losing a good
// sample, LEMI temperatures, the correction r = t n^-1 and the window of a JSON report.
#include "archive_records.hpp"

#include "magnetometer_insitu_calibration/formats/csv_record.hpp"
#include "magnetometer_insitu_calibration/formats/iaga2002.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

#include "archive_fixtures.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <tuple>

namespace mic = magnetometer_insitu_calibration;
using mic::test::same_samples;

namespace {

bool mentions(const std::vector<std::string>& messages, const std::string& text) {
  for (const std::string& m : messages) {
    if (m.find(text) != std::string::npos) return true;
  }
  return false;
}

std::string joined(const std::vector<std::string>& messages) {
  std::string out;
  for (const std::string& m : messages) out += m + "\n";
  return out;
}

/// One hour at 1 Hz, written as IAGA-2002 (CRLF, as the writer does) and read back: the clean
/// record as the strict reader gives it.
struct IagaFixture {
  std::string dir, path;
  mic::VectorRecord clean;
  std::vector<std::string> lines;
  std::size_t first_data = 0;
};

IagaFixture iaga_fixture() {
  IagaFixture f;
  f.dir = mic::test::make_temp_dir("archive_iaga");
  mic::SimulationSettings s;
  s.duration_s = 3600.0;
  s.keep_clean_field = false;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  pair.test.station = "SIM";
  f.path = f.dir + "/clean.sec";
  mic::Iaga2002WriteOptions options;
  options.comments = {"fixture of test_archive_records"};
  mic::write_iaga2002(f.path, pair.test, options);
  f.clean = mic::read_iaga2002(f.path);
  f.lines = mic::test::read_lines(f.path);
  f.first_data = mic::test::iaga_first_data_line(f.lines);
  return f;
}

}  // namespace

// ---- format detection and dispatch -----------------------------------------------------------

TEST(ArchiveRecords, LemiFormatsAreRecognisedAndReadRecordDispatchesThem) {
  const std::string dir = mic::test::make_temp_dir("archive_lemi");
  const double t0 = 1747180800.0;
  mic::SimulationSettings s;
  s.start_time_s = t0 - 0.3;
  s.sample_period_s = 0.1;
  s.duration_s = 120.0;
  s.keep_clean_field = false;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  const auto packets = mic::test::lemi_packets_of(pair.test, t0);
  mic::test::write_lemi_bin_file(dir + "/t.bin", packets);
  mic::test::write_lemi_flash(dir + "/t.flash", packets);
  mic::test::write_lemi_stream(dir + "/t.raw", packets);

  EXPECT_EQ(mic::detect_record_format(dir + "/t.bin"), mic::RecordFormat::kLemiBin);
  EXPECT_EQ(mic::detect_record_format(dir + "/t.flash"), mic::RecordFormat::kLemiCompactFlash);
  EXPECT_EQ(mic::detect_record_format(dir + "/t.raw"), mic::RecordFormat::kLemi025Stream);
  EXPECT_STREQ(mic::record_format_name(mic::RecordFormat::kLemiBin), "LemiBin");

  std::string why;
  const mic::VectorRecord bin = mic::read_record(dir + "/t.bin");
  EXPECT_TRUE(same_samples(bin, mic::read_lemi_bin(dir + "/t.bin"), &why)) << why;
  EXPECT_TRUE(same_samples(mic::read_record(dir + "/t.flash"), mic::read_lemi_compact_flash(dir + "/t.flash"), &why))
      << why;
  EXPECT_TRUE(same_samples(mic::read_record(dir + "/t.raw"), mic::read_lemi025_stream(dir + "/t.raw"), &why)) << why;
  // The three formats hold the same readings: the record at the packets' reading times (float32
  // uT variations of about 1.5 uT in the packets: within 1e-3 nT).
  ASSERT_EQ(bin.size(), pair.test.size());
  for (std::size_t i = 0; i < bin.size(); ++i) {
    ASSERT_NEAR(bin.time_s[i], pair.test.time_s[i], 1e-6) << i;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(bin.values_nT(i, c), pair.test.values_nT(i, c), 1e-3) << i;
  }
  // A capture that starts in the middle of a packet is still a byte stream.
  std::vector<std::uint8_t> bytes;
  {
    std::ifstream in(dir + "/t.raw", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  mic::test::write_bytes(dir + "/cut.raw", std::vector<std::uint8_t>(bytes.begin() + 70, bytes.end()));
  EXPECT_EQ(mic::detect_record_format(dir + "/cut.raw"), mic::RecordFormat::kLemi025Stream);
}

// ---- LEMI through read_archive_record: temperatures and reported damage ------------------------

TEST(ArchiveRecords, LemiTemperaturesAndSkippedBytesAreReported) {
  const std::string dir = mic::test::make_temp_dir("archive_lemi_t");
  const double t0 = 1747180800.0;
  mic::SimulationSettings s;
  s.start_time_s = t0 - 0.3;
  s.sample_period_s = 0.1;
  s.duration_s = 60.0;
  s.keep_clean_field = false;
  const auto packets = mic::test::lemi_packets_of(mic::simulate_pair(s).reference, t0);
  mic::test::write_lemi_stream(dir + "/damaged.raw", packets, {9, 40});
  mic::test::write_lemi_stream(dir + "/clean.raw", packets);

  const mic::ArchiveRecord r = mic::read_archive_record(dir + "/damaged.raw");
  EXPECT_EQ(r.format, mic::RecordFormat::kLemi025Stream);
  EXPECT_EQ(r.skipped, 2u) << joined(r.problems);
  // 37 bytes of noise after packet 9 start at byte 10 * 153.
  EXPECT_TRUE(mentions(r.problems, "damaged.raw byte 1530")) << joined(r.problems);
  EXPECT_TRUE(mentions(r.problems, "damaged.raw byte " + std::to_string(41 * 153 + 37))) << joined(r.problems);
  std::string why;
  EXPECT_TRUE(same_samples(r.record, mic::read_record(dir + "/clean.raw"), &why)) << "nothing good lost: " << why;

  ASSERT_EQ(r.temperatures.size(), packets.size());
  for (std::size_t j = 0; j < packets.size(); ++j) {
    EXPECT_DOUBLE_EQ(r.temperatures.time_s[j], t0 + static_cast<double>(j) - 0.3);  // time of reading 0
    EXPECT_NEAR(r.temperatures.sensor_C[j], mic::test::lemi_sensor_temperature(j), 1e-9);
    EXPECT_NEAR(r.temperatures.electronics_C[j], mic::test::lemi_electronics_temperature(j), 1e-9);
  }
  // Compact flash: the same temperatures; the erased block is not a skipped record.
  mic::test::write_lemi_flash(dir + "/card.flash", packets);
  const mic::ArchiveRecord flash = mic::read_archive_record(dir + "/card.flash");
  EXPECT_EQ(flash.skipped, 0u) << joined(flash.problems);
  EXPECT_TRUE(mentions(flash.problems, "1 erased blocks skipped"));
  ASSERT_EQ(flash.temperatures.size(), packets.size());
  EXPECT_EQ(flash.temperatures.sensor_C, r.temperatures.sensor_C);
}

// ---- text formats with damaged lines ---------------------------------------------------------

TEST(ArchiveRecords, CleanTextFileIsReadExactlyAsReadRecord) {
  const IagaFixture f = iaga_fixture();
  const mic::ArchiveRecord r = mic::read_archive_record(f.path);
  EXPECT_EQ(r.format, mic::RecordFormat::kIaga2002);
  EXPECT_EQ(r.skipped, 0u);
  EXPECT_TRUE(r.problems.empty());
  std::string why;
  EXPECT_TRUE(same_samples(r.record, f.clean, &why)) << why;
  EXPECT_EQ(r.record.header, f.clean.header);
  EXPECT_TRUE(r.temperatures.empty());
}

TEST(ArchiveRecords, DamagedIagaLinesAreNamedSkippedAndNothingGoodIsLost) {
  IagaFixture f = iaga_fixture();
  std::vector<std::string> lines = f.lines;
  const std::size_t d = f.first_data;
  // Sample 100: a malformed number (still 70 columns).
  lines[d + 100].replace(33, 5, "12x45");
  // Sample 200: cut short.
  lines[d + 200] = lines[d + 200].substr(0, 40);
  // Sample 300: stamped a day in the future (a forward clock glitch: only this line is wrong).
  lines[d + 300].replace(0, 10, "2025-05-15");
  lines[d + 300].replace(24, 3, "135");
  // Sample 400 repeated right after itself.
  lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(d + 401), lines[d + 400]);
  const std::string path = f.dir + "/damaged.sec";
  mic::test::write_lines(path, lines, true);

  // The strict reader stops at the first problem and names it.
  try {
    mic::read_iaga2002(path);
    ADD_FAILURE() << "strict reader accepted a damaged file";
  } catch (const mic::InputError& e) {
    EXPECT_EQ(e.where(), path + ":" + std::to_string(d + 101));
  }
  const mic::VectorRecord expected = mic::test::without_samples(f.clean, {100, 200, 300});
  for (const std::size_t block : {8192u, 7u, 1u}) {
    mic::ArchiveReadOptions options;
    options.first_block_lines = block;
    std::vector<double> progress;
    options.progress = [&](double x) { progress.push_back(x); };
    const mic::ArchiveRecord r = mic::read_archive_record(path, options);
    EXPECT_EQ(r.skipped, 4u) << joined(r.problems);
    // 1-based line numbers: data line k is file line d + k + 1; the repeat is line d + 402.
    EXPECT_TRUE(mentions(r.problems, path + ":" + std::to_string(d + 101) + ": ")) << joined(r.problems);
    EXPECT_TRUE(mentions(r.problems, path + ":" + std::to_string(d + 201) + ": ")) << joined(r.problems);
    EXPECT_TRUE(mentions(r.problems, path + ":" + std::to_string(d + 301) + ": time")) << joined(r.problems);
    EXPECT_TRUE(mentions(r.problems, path + ":" + std::to_string(d + 402) + ": time")) << joined(r.problems);
    std::string why;
    EXPECT_TRUE(same_samples(r.record, expected, &why)) << "block " << block << ": " << why;
    EXPECT_EQ(r.record.source, path);
    EXPECT_EQ(r.record.station, "SIM");
    EXPECT_EQ(r.record.components, f.clean.components);
    EXPECT_EQ(r.record.header.at("comments"), "fixture of test_archive_records");
    ASSERT_FALSE(progress.empty());
    EXPECT_DOUBLE_EQ(progress.back(), 1.0);
  }
}

TEST(ArchiveRecords, DamagedCsvLinesAreSkippedWithOrWithoutAHeaderLine) {
  const std::string dir = mic::test::make_temp_dir("archive_csv");
  mic::SimulationSettings s;
  s.duration_s = 600.0;
  s.keep_clean_field = false;
  const mic::SimulatedPair pair = mic::simulate_pair(s);
  mic::VectorRecord record = pair.reference;
  record.components = {"H", "E", "Z"};
  record.header["comments"] = "first comment";
  const std::string clean_path = dir + "/clean.csv";
  mic::write_csv_record(clean_path, record, false, 3);
  const mic::VectorRecord clean = mic::read_csv_record(clean_path);

  std::vector<std::string> lines = mic::test::read_lines(clean_path);
  ASSERT_EQ(lines[0], "# first comment");
  ASSERT_EQ(lines[1].substr(0, 6), "time,H");
  // Data line k is file line k + 3 (comment, header). Damage samples 0 (first data line), 50
  // (a missing column) and 51 (not a number); a comment in the middle is kept as a comment.
  lines[2] = "17471808x0,1,2,3";
  lines[52] = lines[52].substr(0, lines[52].rfind(','));
  lines[53] = lines[53].substr(0, lines[53].find(',')) + ",1,two,3";
  lines.insert(lines.begin() + 300, "# in the middle");
  mic::test::write_lines(dir + "/damaged.csv", lines, false);

  const mic::ArchiveRecord r = mic::read_archive_record(dir + "/damaged.csv");
  EXPECT_EQ(r.skipped, 3u) << joined(r.problems);
  for (const int line : {3, 53, 54}) {
    EXPECT_TRUE(mentions(r.problems, dir + "/damaged.csv:" + std::to_string(line) + ": ")) << line << "\n"
                                                                                          << joined(r.problems);
  }
  std::string why;
  EXPECT_TRUE(same_samples(r.record, mic::test::without_samples(clean, {0, 50, 51}), &why)) << why;
  EXPECT_EQ(r.record.components, clean.components);
  EXPECT_EQ(r.record.header.at("comments"), "first comment\nin the middle");

  // Without a header line (and a semicolon delimiter) the damaged first line is skipped too and
  // the default names stay.
  std::vector<std::string> bare;
  for (std::size_t i = 2; i < 40; ++i) {
    std::string l = lines[i];
    for (char& c : l) c = c == ',' ? ';' : c;
    bare.push_back(l);
  }
  mic::test::write_lines(dir + "/bare.csv", bare, false);
  const mic::ArchiveRecord b = mic::read_archive_record(dir + "/bare.csv");
  EXPECT_EQ(b.skipped, 1u) << joined(b.problems);
  EXPECT_TRUE(mentions(b.problems, dir + "/bare.csv:1: ")) << joined(b.problems);
  EXPECT_EQ(b.record.size(), 37u);
  EXPECT_EQ(b.record.components, (std::array<std::string, 3>{"X", "Y", "Z"}));
  EXPECT_EQ(b.record.time_s.front(), clean.time_s[1]);
  EXPECT_EQ(b.record.values_nT(0, 2), clean.values_nT(1, 2));
}

TEST(ArchiveRecords, FileWithoutAnyGoodRecordOrHeaderIsAnError) {
  const std::string dir = mic::test::make_temp_dir("archive_bad");
  mic::test::write_lines(dir + "/junk.csv", {"time,x,y,z", "a,b,c,d", "1,2"}, false);
  EXPECT_THROW(mic::read_archive_record(dir + "/junk.csv"), mic::InputError);
  EXPECT_THROW(mic::read_archive_record(dir + "/missing.sec"), mic::InputError);
}

// ---- correction and report windows -----------------------------------------------------------

TEST(ArchiveRecords, CorrectionIsRowsTimesTheInverseMatrix) {
  mic::VectorRecord t;
  t.time_s = {1.0, 2.0, 3.0};
  t.values_nT.resize(3, 3);
  t.values_nT << 21000.0, 30.0, 43000.0, 21001.0, 31.0, 43002.0, NAN, NAN, NAN;
  Eigen::Matrix3d n;
  n << 0.9996, 0.0012, -0.0003, -0.0011, 1.0004, 0.0002, 0.0004, -0.0001, 1.0004;
  const mic::VectorRecord r = mic::correct_record(t, n, {"H", "E", "Z"});
  EXPECT_EQ(r.components[1], "E");
  EXPECT_EQ(r.time_s, t.time_s);
  for (int i = 0; i < 2; ++i) {
    // r n = t: the corrected reading maps back onto the test reading.
    const Eigen::RowVector3d back = r.values_nT.row(i) * n;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back(c), t.values_nT(i, c), 1e-9);
  }
  EXPECT_TRUE(r.values_nT.row(2).array().isNaN().all());
  Eigen::Matrix3d singular = n;
  singular.col(2) = singular.col(0);
  EXPECT_THROW(mic::correct_record(t, singular, {"X", "Y", "Z"}), mic::InputError);
}

TEST(ArchiveRecords, ReportWindowIsChosenByIndexLabelOrDefault) {
  nlohmann::json report = {{"windows", nlohmann::json::array()}};
  const std::vector<std::tuple<std::string, std::string, double>> windows = {
      {"interval 1/2", "ok", 1.1}, {"interval 2/2", "low_coherence", 1.2}, {"whole record", "ok", 1.3}};
  for (const auto& [label, quality, scale] : windows) {
    report["windows"].push_back({{"label", label},
                                 {"quality", quality},
                                 {"window_start", "2025-05-14T00:00:00.000Z"},
                                 {"window_end", "2025-05-14T11:59:59.000Z"},
                                 {"matrix", {{scale, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}}});
  }
  EXPECT_EQ(mic::select_report_window(report, "", "r.json").n(0, 0), 1.3);
  EXPECT_EQ(mic::select_report_window(report, "2", "r.json").n(0, 0), 1.2);
  EXPECT_EQ(mic::select_report_window(report, "interval 1/2", "r.json").label, "interval 1/2");
  report["windows"].erase(2);
  EXPECT_EQ(mic::select_report_window(report, "", "r.json").label, "interval 1/2");  // last ok window
  EXPECT_THROW(mic::select_report_window(report, "7", "r.json"), mic::InputError);
  EXPECT_THROW(mic::select_report_window(report, "whole record", "r.json"), mic::InputError);
  report["windows"][0]["matrix"][1][1] = nullptr;
  try {
    mic::select_report_window(report, "1", "r.json");
    ADD_FAILURE();
  } catch (const mic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("matrix[1][1]"), std::string::npos) << e.what();
  }
}
