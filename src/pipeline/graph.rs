//! The stage DAG: topological order, cycle naming, and the `dag` views
//! (text, Graphviz dot, Mermaid).

use petgraph::algo::tarjan_scc;
use petgraph::graph::DiGraph;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Kahn's algorithm, smallest index first, so the order follows the file
/// wherever dependencies allow. On a cycle, returns the nodes of one cycle in
/// edge order.
pub fn topological_order(upstream: &[Vec<usize>]) -> Result<Vec<usize>, Vec<usize>> {
    let n = upstream.len();
    let mut indegree: Vec<usize> = upstream.iter().map(Vec::len).collect();
    let mut downstream = vec![Vec::new(); n];
    for (i, ups) in upstream.iter().enumerate() {
        for &u in ups {
            downstream[u].push(i);
        }
    }
    let mut ready: BinaryHeap<Reverse<usize>> =
        (0..n).filter(|&i| indegree[i] == 0).map(Reverse).collect();
    let mut order = Vec::with_capacity(n);
    while let Some(Reverse(i)) = ready.pop() {
        order.push(i);
        for &d in &downstream[i] {
            indegree[d] -= 1;
            if indegree[d] == 0 {
                ready.push(Reverse(d));
            }
        }
    }
    if order.len() == n {
        Ok(order)
    } else {
        Err(find_cycle(upstream))
    }
}

/// One cycle, as node indices in dependency order (each depends on the previous).
fn find_cycle(upstream: &[Vec<usize>]) -> Vec<usize> {
    let mut g: DiGraph<usize, ()> = DiGraph::new();
    let ids: Vec<_> = (0..upstream.len()).map(|i| g.add_node(i)).collect();
    for (i, ups) in upstream.iter().enumerate() {
        for &u in ups {
            g.add_edge(ids[u], ids[i], ());
        }
    }
    let scc = tarjan_scc(&g)
        .into_iter()
        .find(|c| c.len() > 1 || upstream[c[0].index()].contains(&c[0].index()))
        .unwrap_or_default();
    let members: Vec<usize> = scc.iter().map(|n| n.index()).collect();
    let Some(&start) = members.iter().min() else {
        return Vec::new();
    };
    // Breadth-first over upstream edges inside the component, back to `start`.
    let mut parent: Vec<Option<usize>> = vec![None; upstream.len()];
    let mut queue = std::collections::VecDeque::from([start]);
    let mut visited = vec![false; upstream.len()];
    visited[start] = true;
    while let Some(x) = queue.pop_front() {
        for &u in &upstream[x] {
            if u == start {
                // `x` depends on `start`; each parent depends on its child,
                // and `start` depends on the last one: a cycle in order.
                let mut cycle = vec![start];
                let mut cur = x;
                while cur != start {
                    cycle.push(cur);
                    cur = parent[cur].unwrap_or(start);
                }
                return cycle;
            }
            if members.contains(&u) && !visited[u] {
                visited[u] = true;
                parent[u] = Some(x);
                queue.push_back(u);
            }
        }
    }
    vec![start]
}

/// Output format of `modalflow dag`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DagFormat {
    Text,
    Dot,
    Mermaid,
}

/// Render the DAG: `names[i]` with `labels[i]` (kind), edges from `upstream`.
pub fn render(
    names: &[String],
    labels: &[&str],
    upstream: &[Vec<usize>],
    order: &[usize],
    format: DagFormat,
) -> String {
    let mut out = String::new();
    match format {
        DagFormat::Text => {
            for &i in order {
                let ups: Vec<&str> = upstream[i].iter().map(|&u| names[u].as_str()).collect();
                if ups.is_empty() {
                    out.push_str(&format!("{} ({})\n", names[i], labels[i]));
                } else {
                    out.push_str(&format!(
                        "{} ({}) <- {}\n",
                        names[i],
                        labels[i],
                        ups.join(", ")
                    ));
                }
            }
        }
        DagFormat::Dot => {
            out.push_str("digraph pipeline {\n  rankdir=LR;\n  node [shape=box];\n");
            for &i in order {
                out.push_str(&format!(
                    "  \"{}\" [label=\"{}\\n({})\"];\n",
                    esc(&names[i]),
                    esc(&names[i]),
                    labels[i]
                ));
            }
            for &i in order {
                for &u in &upstream[i] {
                    out.push_str(&format!(
                        "  \"{}\" -> \"{}\";\n",
                        esc(&names[u]),
                        esc(&names[i])
                    ));
                }
            }
            out.push_str("}\n");
        }
        DagFormat::Mermaid => {
            out.push_str("flowchart LR\n");
            for &i in order {
                out.push_str(&format!(
                    "  n{i}[\"{} ({})\"]\n",
                    names[i].replace('"', "'"),
                    labels[i]
                ));
            }
            for &i in order {
                for &u in &upstream[i] {
                    out.push_str(&format!("  n{u} --> n{i}\n"));
                }
            }
        }
    }
    out
}

fn esc(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_respects_edges_and_file_order() {
        // 0 <- 2, 1 independent, 3 <- {1, 2}
        let up = vec![vec![2], vec![], vec![], vec![1, 2]];
        let order = topological_order(&up).unwrap();
        let pos = |x| order.iter().position(|&y| y == x).unwrap();
        assert!(pos(2) < pos(0) && pos(1) < pos(3) && pos(2) < pos(3));
        assert_eq!(order[0], 1);
    }

    #[test]
    fn names_the_cycle_in_order() {
        // a(0) <- c(2), b(1) <- a, c <- b ; d(3) independent
        let up = vec![vec![2], vec![0], vec![1], vec![]];
        let cycle = topological_order(&up).unwrap_err();
        assert_eq!(cycle, vec![0, 1, 2]);
        let self_loop = vec![vec![0]];
        assert_eq!(topological_order(&self_loop).unwrap_err(), vec![0]);
    }
}
