//! Source positions of every node of a YAML document, by path.
//!
//! serde gives positions for syntax and type errors only; semantic checks
//! (unknown kind, missing stage, cycles) happen after deserialization. This
//! index walks the YAML event stream once (yaml-rust2's marked parser) and
//! records where each mapping key and each value starts, so those checks can
//! point at the exact token, block or flow style alike.

use super::diagnostic::Location;
use std::collections::HashMap;
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// Path of a node: mapping keys and sequence indices from the root.
pub type NodePath = Vec<String>;

#[derive(Default, Debug)]
pub struct SpanIndex {
    keys: HashMap<NodePath, Location>,
    values: HashMap<NodePath, Location>,
    /// Mapping keys that appear twice in one mapping (serde would silently
    /// keep the last one), with the position of the repetition.
    pub duplicates: Vec<(NodePath, Location)>,
}

impl SpanIndex {
    /// Index `source`; a document that does not parse yields an empty index
    /// (serde reports the syntax error with its own position).
    pub fn build(source: &str) -> SpanIndex {
        let mut builder = Builder::default();
        let mut parser = Parser::new_from_str(source);
        if parser.load(&mut builder, false).is_err() {
            return SpanIndex::default();
        }
        builder.index
    }

    /// Where the key of the entry at `path` starts (falls back to its value).
    pub fn key(&self, path: &[&str]) -> Option<Location> {
        let p = owned(path);
        self.keys.get(&p).or_else(|| self.values.get(&p)).copied()
    }

    /// Where the value at `path` starts (falls back to its key).
    pub fn value(&self, path: &[&str]) -> Option<Location> {
        let p = owned(path);
        self.values.get(&p).or_else(|| self.keys.get(&p)).copied()
    }

    /// The deepest indexed position along `path`: the node itself or its
    /// nearest ancestor.
    pub fn nearest(&self, path: &[&str]) -> Option<Location> {
        (0..=path.len()).rev().find_map(|n| self.value(&path[..n]))
    }
}

fn owned(path: &[&str]) -> NodePath {
    path.iter().map(|s| s.to_string()).collect()
}

enum Frame {
    Map { pending_key: Option<String> },
    Seq { next: usize },
}

#[derive(Default)]
struct Builder {
    index: SpanIndex,
    stack: Vec<Frame>,
    path: NodePath,
}

impl Builder {
    /// Called when a node (scalar or collection start) begins at `loc`.
    /// Returns whether the node is a mapping key.
    fn begin_node(&mut self, loc: Location, scalar: Option<&str>) -> bool {
        match self.stack.last_mut() {
            Some(Frame::Map { pending_key }) => match pending_key.take() {
                None => {
                    let key = scalar.unwrap_or("<complex key>").to_string();
                    *pending_key = Some(key.clone());
                    let mut p = self.path.clone();
                    p.push(key);
                    match self.index.keys.entry(p) {
                        std::collections::hash_map::Entry::Occupied(e) => {
                            self.index.duplicates.push((e.key().clone(), loc))
                        }
                        std::collections::hash_map::Entry::Vacant(e) => {
                            e.insert(loc);
                        }
                    }
                    true
                }
                Some(key) => {
                    self.path.push(key);
                    self.index.values.insert(self.path.clone(), loc);
                    false
                }
            },
            Some(Frame::Seq { next }) => {
                self.path.push(next.to_string());
                *next += 1;
                self.index.values.insert(self.path.clone(), loc);
                false
            }
            None => {
                self.index.values.insert(Vec::new(), loc);
                false
            }
        }
    }

    /// Called when a value node ends: leave its path segment.
    fn end_value(&mut self) {
        if !self.stack.is_empty() {
            self.path.pop();
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        let loc = Location {
            line: mark.line(),
            column: mark.col() + 1,
        };
        match ev {
            Event::Scalar(ref text, ..) if !self.begin_node(loc, Some(text)) => self.end_value(),
            Event::Alias(_) if !self.begin_node(loc, None) => self.end_value(),
            Event::MappingStart(..) => {
                self.begin_node(loc, None);
                self.stack.push(Frame::Map { pending_key: None });
            }
            Event::SequenceStart(..) => {
                self.begin_node(loc, None);
                self.stack.push(Frame::Seq { next: 0 });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                self.end_value();
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_and_flow_positions() {
        let src = "name: q\nstages:\n  truth:\n    kind: synthesize\n    params: {model: m.yaml, noise: {relative: 0.01}}\n  list: [a, b]\n";
        let ix = SpanIndex::build(src);
        assert_eq!(
            ix.key(&["stages", "truth"]),
            Some(Location { line: 3, column: 3 })
        );
        assert_eq!(
            ix.value(&["stages", "truth", "kind"]),
            Some(Location {
                line: 4,
                column: 11
            })
        );
        assert_eq!(
            ix.value(&["stages", "truth", "params", "noise", "relative"]),
            Some(Location {
                line: 5,
                column: 47
            })
        );
        assert_eq!(
            ix.value(&["stages", "list", "1"]),
            Some(Location {
                line: 6,
                column: 13
            })
        );
        assert_eq!(
            ix.nearest(&["stages", "truth", "params", "missing"]),
            Some(Location {
                line: 5,
                column: 13
            })
        );
    }
}
