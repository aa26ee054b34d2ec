#pragma once

#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

struct ComponentTopology {
    Index vertices = 0, edges = 0, faces = 0;
    int boundary_loops = 0;
    int euler_characteristic = 0;
    int genus = 0;  //!< (2 - chi - b) / 2
};

struct Topology {
    Index vertices = 0, edges = 0, faces = 0;
    int components = 0;
    int boundary_loops = 0;
    int euler_characteristic = 0;  //!< V - E + F over the whole mesh
    int genus = 0;                 //!< sum of the components' genera
    bool orientable = true;        //!< a MeshView is consistently oriented by construction
    std::vector<ComponentTopology> per_component;    //!< ordered by smallest face index
    std::vector<Index> face_component;               //!< #F
    std::vector<std::vector<Index>> boundary_cycles; //!< each loop as an ordered vertex cycle
};

//! Counts, components, ordered boundary loops, Euler characteristic and genus. Linear time.
Topology compute_topology(const MeshView& mesh);

//! One connected component of a mesh, as a mesh of its own.
struct ComponentMesh {
    MeshView mesh;
    std::vector<Index> source_vertex;  //!< per vertex of `mesh`: its id in the whole mesh
};

//! Each component of `mesh` as a mesh of its own, in topology's order: its faces in their
//! order, its vertices in ascending order of their ids, twins kept. \pre topology of `mesh`.
std::vector<ComponentMesh> component_meshes(const MeshView& mesh, const Topology& topology);

}  // namespace holoflow::kernels
