// Files written whole or not at all (porta/slam/atomic_file.hpp): the content arrives complete,
// a failed write leaves the previous file as it was and no temporary behind, and the error names
// the file and the reason.
#include "porta/slam/atomic_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace porta::slam {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("porta_atomic_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  static std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::size_t entries() const { return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator())); }
  fs::path dir_;
};

TEST_F(AtomicFile, ReplacesTheFileWithTheWholeContentAndLeavesNoTemporary) {
  const fs::path file = dir_ / "out.txt";
  write_file_atomically(file.string(), std::string_view("first version\n"));
  const std::string big(1 << 20, 'x');
  write_file_atomically(file.string(), big);
  EXPECT_EQ(read(file), big);
  EXPECT_EQ(entries(), 1u);  // no out.txt.tmp.* left
}

TEST_F(AtomicFile, AFailedWriteKeepsThePreviousFileAndNamesTheProblem) {
  const fs::path folder = dir_ / "a_folder";
  fs::create_directories(folder / "inside");  // renaming a file over a non-empty folder fails
  try {
    write_file_atomically(folder.string(), std::string_view("data"));
    FAIL() << "writing over a folder was accepted";
  } catch (const AtomicWriteError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("cannot write '" + folder.string() + "'"), std::string::npos) << message;
    EXPECT_NE(message.find("renaming over the target"), std::string::npos) << message;
    EXPECT_NE(message.find("is unchanged"), std::string::npos) << message;
  }
  EXPECT_TRUE(fs::is_directory(folder / "inside"));
  EXPECT_EQ(entries(), 1u);  // the temporary was removed

  try {
    write_file_atomically((dir_ / "no" / "such" / "folder.txt").string(), std::string_view("data"));
    FAIL() << "writing into a missing folder was accepted";
  } catch (const AtomicWriteError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create the temporary file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace porta::slam
