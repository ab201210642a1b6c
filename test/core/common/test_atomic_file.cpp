// common/atomic_file.hpp: preparing a file's directory before the first write.
#include "magnetometer_insitu_calibration/common/atomic_file.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace mic = magnetometer_insitu_calibration;
namespace fs = std::filesystem;

namespace {

std::string fresh_directory() {
  std::string pattern = (fs::temp_directory_path() / "mic_atomic_file_XXXXXX").string();
  const char* made = ::mkdtemp(pattern.data());
  if (made == nullptr) throw std::runtime_error("mkdtemp failed");
  return made;
}

std::string contents(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST(PrepareFileDirectory, CreatesMissingDirectoriesAndLeavesNothingBehind) {
  const std::string root = fresh_directory();
  const std::string path = root + "/var/lib/mic/fge.yaml";  // three levels missing
  mic::prepare_file_directory(path);
  EXPECT_TRUE(fs::is_directory(root + "/var/lib/mic"));
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(fs::is_empty(root + "/var/lib/mic"));  // the probe's temporary file is gone
  mic::write_file_atomically(path, "a: 1\n");  // what failed before the directory existed
  EXPECT_EQ(contents(path), "a: 1\n");
  fs::remove_all(root);
}

TEST(PrepareFileDirectory, LeavesAnExistingFileAsItIs) {
  const std::string root = fresh_directory();
  const std::string path = root + "/fge.yaml";
  mic::write_file_atomically(path, "kept\n");
  mic::prepare_file_directory(path);
  mic::prepare_file_directory(path);  // twice: nothing changes
  EXPECT_EQ(contents(path), "kept\n");
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(root)) files += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1u);
  fs::remove_all(root);
}

TEST(PrepareFileDirectory, ABlockedPathIsRefusedNamingIt) {
  const std::string root = fresh_directory();
  const std::string blocker = root + "/not_a_directory";
  mic::write_file_atomically(blocker, "x\n");
  const std::string path = blocker + "/mic/fge.yaml";  // a directory would have to be made inside a file
  try {
    mic::prepare_file_directory(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& error) {
    const std::string text = error.what();
    EXPECT_NE(text.find(path), std::string::npos) << text;
    EXPECT_NE(text.find("cannot create directory"), std::string::npos) << text;
  }
  EXPECT_THROW(mic::prepare_file_directory(root + "/dir/"), std::runtime_error);  // no file name
  EXPECT_THROW(mic::prepare_file_directory(""), std::runtime_error);
  EXPECT_EQ(contents(blocker), "x\n");
  fs::remove_all(root);
}
