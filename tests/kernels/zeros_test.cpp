#include "holoflow/kernels/zeros.h"

#include <gtest/gtest.h>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/shapes.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

ZeroSet zeros_of(const MeshView& mesh) {
    const engine::ConformalResult c = engine::compute_conformal(mesh);
    return find_zeros(*c.surface, c.tau);
}

TEST(Zeros, CorpusCountIsExactlyTwoGenusMinusTwo) {
    for (const auto& [name, genus] : {std::pair{"eight", 2}, {"femur", 2}, {"elephant", 3}, {"helmet", 3},
                                      {"anchor", 4}, {"couplingdown", 9}}) {
        SCOPED_TRACE(name);
        const ZeroSet z = zeros_of(*test::corpus_mesh(name));
        EXPECT_EQ(z.total_index, 2 * genus - 2);
        EXPECT_EQ(z.total_order, 2 * genus - 2);
        int orders = 0;
        for (const Zero& zero : z.zeros) orders += zero.order;
        EXPECT_EQ(orders, 2 * genus - 2);
        std::printf("%s: zeros %zu clusters %zu artifacts %d merged %d nonpositive w %d flips %d\n", name,
                    z.zeros.size(), z.clusters.size(), z.artifact_clusters, z.merged_negative_clusters,
                    z.nonpositive_winding_vertices,
                    static_cast<int>(std::count(z.face_flip.begin(), z.face_flip.end(), 1)));
    }
}

TEST(Zeros, TorusHasNone) {
    const ZeroSet z = zeros_of(shapes::torus(2, 1, 48, 24));
    EXPECT_EQ(z.total_index, 0);
    EXPECT_TRUE(z.zeros.empty());
    EXPECT_EQ(z.artifact_clusters, 0);
}

}  // namespace
}  // namespace holoflow::kernels
