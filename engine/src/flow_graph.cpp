#include "holoflow/engine/flow_graph.h"

#include <algorithm>

namespace holoflow::engine {

Graph::Graph()
    : context_(tbb::task_group_context::isolated,
               tbb::task_group_context::default_traits | tbb::task_group_context::fp_settings),
      graph_(context_) {}

void Graph::record_edge(const void* from, const void* to, std::string label) {
    const auto index = [&](const void* node) {
        const auto it = std::find(addresses_.begin(), addresses_.end(), node);
        return static_cast<std::size_t>(it - addresses_.begin());  // == size(): not a node of ours
    };
    edges_.push_back({index(from), index(to), std::move(label)});
}

void Graph::to_dot(std::ostream& out, const std::string& title) const {
    out << "digraph \"" << title << "\" {\n  rankdir=TB;\n  node [shape=box, fontname=\"Helvetica\"];\n";
    for (std::size_t i = 0; i < names_.size(); ++i) out << "  n" << i << " [label=\"" << names_[i] << "\"];\n";
    for (const Edge& e : edges_) {
        if (e.from >= names_.size() || e.to >= names_.size()) continue;
        out << "  n" << e.from << " -> n" << e.to;
        if (!e.label.empty()) out << " [label=\"" << e.label << "\"]";
        out << ";\n";
    }
    out << "}\n";
}

}  // namespace holoflow::engine
