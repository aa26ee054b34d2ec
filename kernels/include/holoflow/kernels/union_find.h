#pragma once

#include <algorithm>
#include <numeric>
#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Disjoint sets over 0 .. n-1 with path halving; the root of a set is its smallest member, so
//! scanning elements in order meets every root first (deterministic numbering of the sets).
struct UnionFind {
    std::vector<Index> parent;
    explicit UnionFind(Index n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
    Index find(Index x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    }
    void unite(Index a, Index b) {
        a = find(a), b = find(b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
};

}  // namespace holoflow::kernels
