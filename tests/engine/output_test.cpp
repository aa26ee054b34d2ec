// Output folders and files: sets written as a whole, the lock that keeps a second run out, and
// the temporaries of killed runs.
#include "holoflow/engine/output.h"

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "support/test_support.h"

namespace holoflow::engine {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::TempDir;

std::vector<std::string> folder_entries(const fs::path& folder) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

void write_set(const fs::path& folder, const std::string& content) {
    FileSet files;
    files.add(folder / "a.txt", content);
    files.add(folder / "marker.json", content);
    files.commit();
}

TEST(FileSet, AFailedSetLeavesTheEarlierOneWholeAndNoTemporaries) {
    const TempDir dir;
    write_set(dir.path(), "old");
    {
        FileSet files;
        files.add(dir.path() / "a.txt", "new");
        EXPECT_THROW(files.add(dir.path() / "marker.json", [](std::ostream&) { throw OutputError("refused"); }),
                     OutputError);
    }  // dropped before commit
    EXPECT_EQ(folder_entries(dir.path()), (std::vector<std::string>{"a.txt", "marker.json"}));
    EXPECT_EQ(slurp(dir.path() / "a.txt"), "old");
    EXPECT_EQ(slurp(dir.path() / "marker.json"), "old");

    write_set(dir.path(), "new");
    EXPECT_EQ(slurp(dir.path() / "a.txt"), "new");
    EXPECT_EQ(slurp(dir.path() / "marker.json"), "new");
}

TEST(FileSet, AFolderInAFilesPlaceStopsTheCommitBeforeAnyChange) {
    const TempDir dir;
    write_set(dir.path(), "old");
    FileSet files;
    files.add(dir.path() / "a.txt", "new");
    files.add(dir.path() / "b", "new");
    files.add(dir.path() / "marker.json", "new");
    fs::create_directories(dir.path() / "b" / "in the way");
    try {
        files.commit();
        ADD_FAILURE() << "committed over a folder";
    } catch (const OutputError& e) {
        EXPECT_NE(std::string(e.what()).find("a folder or special file is in its place"), std::string::npos) << e.what();
    }
    EXPECT_EQ(slurp(dir.path() / "a.txt"), "old");
    EXPECT_EQ(slurp(dir.path() / "marker.json"), "old");
    EXPECT_TRUE(fs::exists(dir.path() / "b" / "in the way"));
}

TEST(FileSet, ARenameThatFailsHalfWayPutsTheOldSetBack) {
    const TempDir dir;
    write_set(dir.path(), "old");
    dir.write("b", "old");
    {
        FileSet files;
        files.add(dir.path() / "a.txt", "new");
        files.add(dir.path() / "b", "new");
        files.add(dir.path() / "marker.json", "new");
        // b's temporary vanishes (as if removed by hand): its rename fails after a.txt's.
        fs::remove(dir.path() / (".b.tmp" + std::to_string(::getpid())));
        EXPECT_THROW(files.commit(), OutputError);
    }
    EXPECT_EQ(folder_entries(dir.path()), (std::vector<std::string>{"a.txt", "b", "marker.json"}));
    for (const char* name : {"a.txt", "b", "marker.json"}) EXPECT_EQ(slurp(dir.path() / name), "old") << name;
}

TEST(RemoveStaleTemporaries, OnlyThoseOfEndedProcesses) {
    const TempDir dir;
    const pid_t child = ::fork();
    if (child == 0) ::_exit(0);
    ASSERT_GT(child, 0);
    ASSERT_EQ(::waitpid(child, nullptr, 0), child);  // its pid names no process now
    const std::string dead = ".a.txt.tmp" + std::to_string(child), live = ".a.txt.tmp" + std::to_string(::getpid());
    dir.write(dead, "x");
    dir.write(".a.txt.old" + std::to_string(child), "x");  // a killed commit's old file, moved aside
    dir.write(live, "x");
    dir.write(".other.txt.tmp1", "x");  // not one of the names: the user's
    remove_stale_temporaries(dir.path(), {"a.txt"});
    EXPECT_EQ(folder_entries(dir.path()), (std::vector<std::string>{".a.txt.tmp" + std::to_string(::getpid()),
                                                                     ".other.txt.tmp1"}));
}

TEST(OutputFolder, ASecondRunIsRefusedUntilTheFirstEnds) {
    const TempDir dir;
    const fs::path out = dir.path() / "out";
    {
        const OutputFolder first(out);
        EXPECT_TRUE(fs::exists(out / kOutputLockFile));
        try {
            const OutputFolder second(out);
            ADD_FAILURE() << "a second holder of the folder";
        } catch (const OutputError& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("in use by another holoflow run (process " + std::to_string(::getpid()) + ")"),
                      std::string::npos)
                << message;
        }
        dir.write("out/result.txt", "x");
    }
    EXPECT_EQ(folder_entries(out), std::vector<std::string>{"result.txt"}) << "the lock file is removed";
    const OutputFolder again(out);
}

TEST(OutputFolder, FoldersItCreatedAreRemovedIfLeftEmpty) {
    const TempDir dir;
    { const OutputFolder unused(dir.path() / "a" / "b" / "c"); }
    EXPECT_EQ(folder_entries(dir.path()), std::vector<std::string>{}) << "a, b and c were created for nothing";
    fs::create_directories(dir.path() / "mine");
    { const OutputFolder existing(dir.path() / "mine" / "new/"); }
    EXPECT_EQ(folder_entries(dir.path()), std::vector<std::string>{"mine"}) << "the user's folder stays";
    const std::string file = dir.write("file", "x");
    EXPECT_THROW(OutputFolder(fs::path(file) / "sub"), OutputError);
}

}  // namespace
}  // namespace holoflow::engine
