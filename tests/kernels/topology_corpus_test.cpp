// Topology of the real libcgal-demo meshes (unpacked by CMake into HOLOFLOW_CORPUS_DIR). The
// corpus is part of the build, so a missing file is a failure, not a skip.
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {


struct Expected {
    const char* name;
    int genus;
    int boundary_loops;
    int components;
};

void PrintTo(const Expected& e, std::ostream* os) { *os << e.name; }

class CorpusTopology : public testing::TestWithParam<Expected> {};

TEST_P(CorpusTopology, MatchesKnownValues) {
    const Expected& expected = GetParam();
    const auto mesh = test::corpus_mesh(expected.name);
    const Topology t = compute_topology(*mesh);
    EXPECT_EQ(t.genus, expected.genus);
    EXPECT_EQ(t.boundary_loops, expected.boundary_loops);
    EXPECT_EQ(mesh->is_closed(), expected.boundary_loops == 0);
    EXPECT_EQ(t.components, expected.components);
    // chi = sum over components of 2 - 2g - b.
    EXPECT_EQ(t.euler_characteristic,
              2 * expected.components - 2 * expected.genus - expected.boundary_loops);
}

// Genus and boundary counts as documented for the libcgal-demo data (DESIGN.md section 4).
INSTANTIATE_TEST_SUITE_P(
    Libcgal, CorpusTopology,
    testing::Values(Expected{"eight", 2, 0, 1}, Expected{"femur", 2, 0, 1},
                    Expected{"elephant", 3, 0, 1}, Expected{"helmet", 3, 0, 1},
                    Expected{"anchor", 4, 0, 1}, Expected{"couplingdown", 9, 0, 1},
                    Expected{"turbine", 11, 0, 1}, Expected{"cheese", 133, 0, 1},
                    Expected{"knot", 1, 0, 1}, Expected{"rotor", 1, 0, 1},
                    Expected{"head", 0, 3, 1}, Expected{"lion", 0, 5, 1},
                    Expected{"mech-holes-shark", 0, 4, 1}, Expected{"bones", 0, 0, 26}),
    [](const testing::TestParamInfo<Expected>& param) {
        std::string name = param.param.name;
        for (char& c : name)
            if (c == '-') c = '_';
        return name;
    });

TEST(CorpusTopology, DoubleCoversOfHeadAndLion) {
    // head: genus 0, 3 boundary loops; lion: genus 0, 5. The double has genus 2g + b - 1.
    for (const auto& [name, genus] : {std::pair{"head", 2}, std::pair{"lion", 4}}) {
        SCOPED_TRACE(name);
        const DoubleCover dc = double_cover(*test::corpus_mesh(name));
        EXPECT_TRUE(dc.mesh.is_closed());
        const Topology t = compute_topology(dc.mesh);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.genus, genus);
    }
}

TEST(CorpusTopology, MidpointSubdivisionOfEightKeepsGenusTwo) {
    const auto eight = test::corpus_mesh("eight");
    const MeshView fine = subdivide_midpoint(*eight);
    EXPECT_EQ(fine.n_faces(), 4 * eight->n_faces());
    const Topology t = compute_topology(fine);
    EXPECT_EQ(t.genus, 2);
    EXPECT_TRUE(fine.is_closed());
}

}  // namespace
}  // namespace holoflow::kernels
