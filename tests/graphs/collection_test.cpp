// A collection run: models an earlier run finished are reused, failures stay per model, and the
// flow graph writes what its serial twin writes. (The memory share and its rerun are driven
// through `holoflow batch` in engine_batch_test.)
#include "holoflow/graphs/collection.h"

#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/test_support.h"

namespace holoflow::graphs {
namespace {

using test::corpus;
using test::slurp;
using test::TempDir;

TEST(Collection, ReusesFinishedModelsAndMatchesTheSerialTwin) {
    const TempDir dir;
    std::vector<std::string> paths;
    for (const char* model : {"eight.off", "knot.off"}) paths.push_back(corpus(model));
    paths.insert(paths.begin() + 1, dir.write("broken.off", "OFF\n3 1 0\n0 0 0\n"));
    CollectionOptions options;
    options.threads = 2;
    options.settings = {{"case", "collection_test"}};
    std::ostringstream log;  // progress lines and the rerun line
    const auto run = [&](const std::string& folder, bool serial, bool force) {
        options.serial = serial;
        options.force = force;
        engine::BatchProgress progress(paths.size(), log, false);
        return run_collection(engine::make_tasks(paths, dir.path() / folder), options, progress, log);
    };
    const CollectionRun first = run("graph", false, false);
    ASSERT_EQ(first.outcomes.size(), 3u);
    EXPECT_TRUE(first.outcomes[0].status.ok()) << first.outcomes[0].status.message;
    EXPECT_EQ(first.outcomes[1].status.kind, "header_mismatch");
    EXPECT_TRUE(first.outcomes[2].status.ok()) << first.outcomes[2].status.message;
    EXPECT_EQ(first.reused, 0u);
    EXPECT_TRUE(first.recomputed_alone.empty());

    const CollectionRun again = run("graph", false, false);  // the failed model is tried again
    EXPECT_EQ(again.reused, 2u);
    EXPECT_EQ(again.outcomes[0].patches, first.outcomes[0].patches);
    EXPECT_EQ(again.outcomes[1].status.kind, "header_mismatch");
    EXPECT_EQ(run("graph", false, true).reused, 0u);

    run("serial", true, false);
    for (const char* model : {"eight", "knot"})
        for (const char* file : {"segments.ply", "patches.obj", "trajectories.obj", "complex.json"})
            EXPECT_EQ(slurp(dir.path() / "graph" / model / file), slurp(dir.path() / "serial" / model / file))
                << model << "/" << file;
}

}  // namespace
}  // namespace holoflow::graphs
