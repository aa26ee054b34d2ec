#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/task_group.h>

#include "holoflow/engine/status.h"

namespace holoflow::engine {

//! A flow-graph message: the item's id (its position in the input, so collectors order by it,
//! never by arrival) and its state. Along a chain of stage nodes one node at a time holds the
//! state, so stages mutate it in place instead of copying meshes from node to node.
template <class State>
struct Item {
    std::uint64_t id = 0;
    std::shared_ptr<State> state;
};

//! A oneTBB flow graph that owns its nodes, remembers their names and edges and prints itself
//! as a DOT diagram. Its tasks run in an isolated context that captured the caller's
//! floating-point settings.
class Graph {
  public:
    Graph();
    //! Waits for the tasks still queued (a node's forwarding task) before the nodes go.
    ~Graph() { graph_.wait_for_all(); }
    Graph(const Graph&) = delete;
    Graph& operator=(const Graph&) = delete;

    //! Constructs a node of type Node on this graph: Node(graph, args...).
    template <class Node, class... Args>
    Node& add(std::string name, Args&&... args) {
        auto node = std::make_unique<Node>(graph_, std::forward<Args>(args)...);
        Node& ref = *node;
        names_.push_back(std::move(name));
        addresses_.push_back(&ref);
        nodes_.push_back(std::move(node));
        return ref;
    }

    //! make_edge(from, to), recorded for to_dot.
    template <class From, class To>
    void connect(From& from, To& to, std::string label = {}) {
        tbb::flow::make_edge(from, to);
        record_edge(&from, &to, std::move(label));
    }
    //! Output port `Port` of a multi-output node to `to`.
    template <std::size_t Port, class From, class To>
    void connect_port(From& from, To& to, std::string label) {
        tbb::flow::make_edge(tbb::flow::output_port<Port>(from), to);
        record_edge(&from, &to, std::move(label));
    }
    //! `from` to the decrement port of a limiter_node.
    template <class From, class Limiter>
    void connect_decrement(From& from, Limiter& limiter) {
        tbb::flow::make_edge(from, limiter.decrementer());
        record_edge(&from, &limiter, "decrement");
    }

    void wait_for_all() { graph_.wait_for_all(); }

    //! The nodes and edges as a Graphviz digraph, in the order they were added.
    void to_dot(std::ostream& out, const std::string& title) const;

  private:
    struct Edge {
        std::size_t from, to;
        std::string label;
    };
    void record_edge(const void* from, const void* to, std::string label);

    tbb::task_group_context context_;
    tbb::flow::graph graph_;
    std::vector<std::unique_ptr<tbb::flow::graph_node>> nodes_;  // destroyed before graph_
    std::vector<std::string> names_;
    std::vector<const void*> addresses_;
    std::vector<Edge> edges_;
};

//! Runs one stage on a model's state, the same way in a graph node and in a serial twin: a state
//! that already failed passes untouched; one past its deadline fails with `timeout`; an exception
//! becomes the state's failure (kind from status_from_exception), so nothing escapes into the
//! graph and one bad model never cancels the others. State needs `Status status`,
//! `std::chrono::steady_clock::time_point deadline` and `void release()` (drops the heavy data of
//! a failed model).
template <class State, class Stage>
void run_stage(State& state, const std::string& stage_name, const Stage& stage) {
    if (!state.status.ok()) return;
    if (std::chrono::steady_clock::now() > state.deadline) {
        state.status = Status::failure("timeout", stage_name, "time limit reached before this stage",
                                       kExitTimeout);
    } else {
        try {
            stage(state);
            return;
        } catch (...) {
            state.status = status_from_exception(std::current_exception(), stage_name);
        }
    }
    state.release();
}

//! A function_node running `stage` on every item (run_stage semantics), unlimited concurrency:
//! one task per model in flight (the limiter upstream bounds them).
template <class State, class Stage>
tbb::flow::function_node<Item<State>, Item<State>>& add_stage_node(Graph& graph, const std::string& name,
                                                                   Stage stage) {
    return graph.add<tbb::flow::function_node<Item<State>, Item<State>>>(
        name, tbb::flow::unlimited, [stage, name](Item<State> item) {
            run_stage(*item.state, name, stage);
            return item;
        });
}

}  // namespace holoflow::engine
