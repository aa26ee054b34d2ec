#include "holoflow/engine/report.h"

#include <sstream>

namespace holoflow::engine {

nlohmann::json info_report(const std::string& path, const LoadedMesh& loaded,
                           const kernels::Topology& topology) {
    const LoadReport& r = loaded.report;
    nlohmann::json repairs = {
        {"triangulated_polygons", r.triangulated_polygons},
        {"triangles_from_polygons", r.triangles_from_polygons},
        {"reoriented_faces", r.reoriented_faces},
        {"unreferenced_vertices", r.unreferenced_vertices},
        {"welded_vertices", r.welded_vertices},
        {"ignored_lines", r.ignored_lines},
        {"split_vertices", r.split_vertices},
        {"collapsed_edges", r.collapsed_edges},
        {"collapsed_faces", r.collapsed_faces},
        {"flipped_edges", r.flipped_edges},
        {"duplicate_faces", r.duplicate_faces},
        {"split_edges", r.split_edges},
        {"zipped_edges", r.zipped_edges},
        {"zipped_vertices", r.zipped_vertices},
        {"dropped_components", r.dropped_components},
        {"dropped_faces", r.dropped_faces},
    };
    nlohmann::json components = nlohmann::json::array();
    for (const auto& c : topology.per_component)
        components.push_back({{"vertices", c.vertices},
                              {"edges", c.edges},
                              {"faces", c.faces},
                              {"boundary_loops", c.boundary_loops},
                              {"euler_characteristic", c.euler_characteristic},
                              {"genus", c.genus}});
    nlohmann::json loop_lengths = nlohmann::json::array();
    for (const auto& loop : topology.boundary_cycles) loop_lengths.push_back(loop.size());
    return {
        {"file", path},
        {"file_vertices", r.file_vertices},
        {"file_polygons", r.file_polygons},
        {"vertices", topology.vertices},
        {"edges", topology.edges},
        {"faces", topology.faces},
        {"components", topology.components},
        {"boundary_loops", topology.boundary_loops},
        {"boundary_loop_lengths", loop_lengths},
        {"euler_characteristic", topology.euler_characteristic},
        {"genus", topology.genus},
        {"orientable", topology.orientable},
        {"closed", topology.boundary_loops == 0},
        {"component_topology", components},
        {"repairs", repairs},
    };
}

std::string format_info_text(const nlohmann::json& report) {
    std::ostringstream out;
    out << "file                  " << report["file"].get<std::string>() << "\n";
    for (const char* key : {"vertices", "edges", "faces", "components", "boundary_loops",
                            "euler_characteristic", "genus"})
        out << key << std::string(22 - std::string(key).size(), ' ') << report[key] << "\n";
    out << "orientable            " << (report["orientable"].get<bool>() ? "yes" : "no") << "\n";
    out << "repairs              ";
    bool any = false;
    for (const auto& [name, count] : report["repairs"].items())
        if (count.get<std::size_t>() > 0) {
            out << " " << name << "=" << count;
            any = true;
        }
    out << (any ? "\n" : " none\n");
    return out.str();
}

}  // namespace holoflow::engine
