//! Reader for the mesh part of Abaqus / CalculiX `.inp` decks.
//!
//! Understood keywords: `*NODE` (optionally `NSET=`), `*ELEMENT, TYPE=, ELSET=`,
//! `*NSET, NSET=` and `*ELSET, ELSET=` (plain lists, `GENERATE`, references to other sets by
//! name, `*NSET, ELSET=` for the nodes of element sets). Keywords are case-insensitive,
//! set names are matched case-insensitively (and keep the spelling of their first use),
//! `**` starts a comment, a trailing comma continues a keyword line or an element's node
//! list. Every other keyword and its data lines are skipped. `*INCLUDE` is an error.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use cellmech_fem::mesh::{ElementBlock, ElementKind, Mesh};

use crate::error::{read_text, ReadError};
use crate::lines::{parse_finite, parse_token, Lines};

/// One element of a [`Mesh`]: block index and element index inside the block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ElementRef {
    /// Index into [`Mesh::blocks`].
    pub block: usize,
    /// Element index inside the block.
    pub element: usize,
}

/// The mesh of an Abaqus deck plus what does not fit into [`Mesh`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AbaqusDeck {
    /// Nodes, one block per (`*ELEMENT` ELSET, element kind), node sets from `*NODE, NSET=`
    /// and `*NSET`.
    pub mesh: Mesh,
    /// Every named element set (from `*ELEMENT, ELSET=` and `*ELSET`), sorted, unique.
    pub element_sets: BTreeMap<String, Vec<ElementRef>>,
    /// The Abaqus label of each node (index = 0-based node index).
    pub node_labels: Vec<i64>,
}

impl AbaqusDeck {
    /// The 0-based index of the node with Abaqus label `label`.
    pub fn node_index(&self, label: i64) -> Option<usize> {
        self.node_labels.iter().position(|&l| l == label)
    }
}

/// Reads an Abaqus / CalculiX `.inp` file.
pub fn read_abaqus(path: &Path) -> Result<AbaqusDeck, ReadError> {
    let text = read_text(path)?;
    parse_abaqus(&text, &path.display().to_string())
}

/// Maps an Abaqus element type (upper case) to an [`ElementKind`].
pub fn abaqus_element_kind(abaqus_type: &str) -> Option<ElementKind> {
    Some(match abaqus_type.to_ascii_uppercase().as_str() {
        "C3D8" | "C3D8H" | "C3D8R" | "C3D8I" => ElementKind::Hex8,
        "C3D4" => ElementKind::Tet4,
        "C3D10" => ElementKind::Tet10,
        "C3D6" => ElementKind::Wedge6,
        "C3D20" | "C3D20R" => ElementKind::Hex20,
        "S4" | "S4R" | "M3D4" => ElementKind::Quad4,
        "S3" | "M3D3" => ElementKind::Tri3,
        "T3D2" | "B31" => ElementKind::Line2,
        _ => return None,
    })
}

/// Parses deck text; `file` names the source in error messages.
pub fn parse_abaqus(text: &str, file: &str) -> Result<AbaqusDeck, ReadError> {
    let mut lines = Lines::new(text, file);
    let mut p = Parser::default();
    let mut mode = Mode::Skip;
    while let Some((no, line)) = lines.next_line() {
        if line.is_empty() || line.starts_with("**") {
            continue;
        }
        if line.starts_with('*') {
            p.finish(&lines, &mode)?;
            let mut keyword = line.to_string();
            while keyword.ends_with(',') {
                match lines.peek() {
                    Some((_, next)) if !next.starts_with('*') => {
                        keyword.push_str(next);
                        lines.next_line();
                    }
                    _ => break,
                }
            }
            mode = p.keyword(&lines, no, &keyword)?;
        } else {
            p.data(&lines, no, line, &mut mode)?;
        }
    }
    p.finish(&lines, &mode)?;
    Ok(p.into_deck())
}

/// What the data lines after the current keyword mean.
enum Mode {
    Skip,
    Node {
        nset: Option<String>,
    },
    Element {
        kind: ElementKind,
        block: usize,
        elset: Option<String>,
        pending: Pending,
    },
    Nset {
        name: String,
        generate: bool,
    },
    Elset {
        name: String,
        generate: bool,
    },
}

/// Node labels of an element whose list continues over several lines.
#[derive(Default)]
struct Pending {
    first_line: usize,
    tokens: Vec<String>,
}

#[derive(Default)]
struct Parser {
    nodes: Vec<[f64; 3]>,
    node_labels: Vec<i64>,
    node_index: HashMap<i64, usize>,
    blocks: Vec<ElementBlock>,
    block_index: HashMap<(String, ElementKind), usize>,
    element_index: HashMap<i64, ElementRef>,
    /// Upper-case set name -> (spelling of first use, members).
    nsets: BTreeMap<String, (String, Vec<usize>)>,
    elsets: BTreeMap<String, (String, Vec<ElementRef>)>,
}

/// Splits `*KEYWORD, A=b, FLAG` into the upper-case keyword and upper-case parameter keys.
fn split_keyword(line: &str) -> (String, Vec<(String, String)>) {
    let mut parts = line.trim_start_matches('*').split(',');
    let name = parts
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let params = parts
        .filter(|p| !p.trim().is_empty())
        .map(|p| match p.split_once('=') {
            Some((k, v)) => (k.trim().to_ascii_uppercase(), v.trim().to_string()),
            None => (p.trim().to_ascii_uppercase(), String::new()),
        })
        .collect();
    (name.to_ascii_uppercase(), params)
}

fn param<'p>(params: &'p [(String, String)], key: &str) -> Option<&'p str> {
    params
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

fn data_tokens(line: &str) -> Vec<&str> {
    let mut tokens: Vec<&str> = line.split(',').map(str::trim).collect();
    if tokens.last() == Some(&"") {
        tokens.pop();
    }
    tokens
}

impl Parser {
    fn keyword(&mut self, lines: &Lines<'_>, no: usize, line: &str) -> Result<Mode, ReadError> {
        let (name, params) = split_keyword(line);
        let required = |key: &str| {
            param(&params, key)
                .filter(|v| !v.is_empty())
                .map(str::to_string)
                .ok_or_else(|| {
                    lines.error(
                        no,
                        format!("*{name} needs the parameter {key}=, found '{line}'"),
                    )
                })
        };
        Ok(match name.as_str() {
            "NODE" => Mode::Node {
                nset: param(&params, "NSET").map(str::to_string),
            },
            "ELEMENT" => {
                let abaqus_type = required("TYPE")?;
                let kind = abaqus_element_kind(&abaqus_type).ok_or_else(|| {
                    lines.error(
                        no,
                        format!(
                            "element type {abaqus_type} is not supported (supported: C3D8, \
                             C3D8H, C3D8R, C3D8I, C3D4, C3D10, C3D6, C3D20, C3D20R, S4, S4R, \
                             M3D4, S3, M3D3, T3D2, B31)"
                        ),
                    )
                })?;
                let elset = param(&params, "ELSET").map(str::to_string);
                let block_name = match &elset {
                    Some(s) => self.elset_spelling(s),
                    None => format!("elements_{}", abaqus_type.to_ascii_uppercase()),
                };
                let next = self.blocks.len();
                let key = (block_name.to_ascii_uppercase(), kind);
                let block = *self.block_index.entry(key).or_insert(next);
                if block == next {
                    self.blocks.push(ElementBlock {
                        name: block_name,
                        kind,
                        connectivity: Vec::new(),
                    });
                }
                Mode::Element {
                    kind,
                    block,
                    elset,
                    pending: Pending::default(),
                }
            }
            "NSET" => {
                let set = required("NSET")?;
                let generate = param(&params, "GENERATE").is_some();
                self.nsets
                    .entry(set.to_ascii_uppercase())
                    .or_insert_with(|| (set.clone(), Vec::new()));
                if let Some(elsets) = param(&params, "ELSET") {
                    self.nodes_of_elset(lines, no, &set, elsets)?;
                }
                Mode::Nset {
                    name: set,
                    generate,
                }
            }
            "ELSET" => {
                let set = required("ELSET")?;
                let generate = param(&params, "GENERATE").is_some();
                self.elsets
                    .entry(set.to_ascii_uppercase())
                    .or_insert_with(|| (set.clone(), Vec::new()));
                Mode::Elset {
                    name: set,
                    generate,
                }
            }
            "INCLUDE" => {
                return Err(lines.error(
                    no,
                    "*INCLUDE is not supported; paste the included file into the deck",
                ))
            }
            _ => Mode::Skip,
        })
    }

    fn elset_spelling(&self, name: &str) -> String {
        self.elsets
            .get(&name.to_ascii_uppercase())
            .map(|(s, _)| s.clone())
            .unwrap_or_else(|| name.to_string())
    }

    fn data(
        &mut self,
        lines: &Lines<'_>,
        no: usize,
        line: &str,
        mode: &mut Mode,
    ) -> Result<(), ReadError> {
        match mode {
            Mode::Skip => Ok(()),
            Mode::Node { nset } => {
                let nset = nset.clone();
                self.node_line(lines, no, line, nset.as_deref())
            }
            Mode::Element {
                kind,
                block,
                elset,
                pending,
            } => {
                if pending.tokens.is_empty() {
                    pending.first_line = no;
                }
                pending
                    .tokens
                    .extend(data_tokens(line).into_iter().map(str::to_string));
                let needed = kind.nodes_per_element() + 1;
                if pending.tokens.len() > needed {
                    return Err(lines.error(
                        no,
                        format!(
                            "expected {} node labels for a {} element, found {}",
                            needed - 1,
                            kind.name(),
                            pending.tokens.len() - 1
                        ),
                    ));
                }
                if pending.tokens.len() == needed {
                    let tokens = std::mem::take(&mut pending.tokens);
                    let elset = elset.clone();
                    self.element(lines, pending.first_line, &tokens, *block, elset.as_deref())?;
                }
                Ok(())
            }
            Mode::Nset { name, generate } => {
                let labels = self.set_members(lines, no, line, *generate, true)?;
                let referenced_set = labels.iter().any(|m| matches!(m, Member::Set(_)));
                let mut indices = Vec::with_capacity(labels.len());
                for member in labels {
                    match member {
                        Member::Label(label) => {
                            indices.push(*self.node_index.get(&label).ok_or_else(|| {
                                lines.error(
                                    no,
                                    format!("node set {name} refers to node {label}, which is not defined"),
                                )
                            })?)
                        }
                        Member::Set(key) => indices.extend(self.nsets[&key].1.iter().copied()),
                    }
                }
                let key = name.to_ascii_uppercase();
                if let Some(set) = self.nsets.get_mut(&key) {
                    set.1.extend(indices);
                    if referenced_set {
                        // A set that names itself (or two that name each other) would double
                        // on every line; the order does not matter (sorted at the end).
                        set.1.sort_unstable();
                        set.1.dedup();
                    }
                }
                Ok(())
            }
            Mode::Elset { name, generate } => {
                let labels = self.set_members(lines, no, line, *generate, false)?;
                let referenced_set = labels.iter().any(|m| matches!(m, Member::Set(_)));
                let mut refs = Vec::with_capacity(labels.len());
                for member in labels {
                    match member {
                        Member::Label(label) => {
                            refs.push(*self.element_index.get(&label).ok_or_else(|| {
                                lines.error(
                                    no,
                                    format!("element set {name} refers to element {label}, which is not defined"),
                                )
                            })?)
                        }
                        Member::Set(key) => refs.extend(self.elsets[&key].1.iter().copied()),
                    }
                }
                let key = name.to_ascii_uppercase();
                if let Some(set) = self.elsets.get_mut(&key) {
                    set.1.extend(refs);
                    if referenced_set {
                        set.1.sort_unstable();
                        set.1.dedup();
                    }
                }
                Ok(())
            }
        }
    }

    fn node_line(
        &mut self,
        lines: &Lines<'_>,
        no: usize,
        line: &str,
        nset: Option<&str>,
    ) -> Result<(), ReadError> {
        let tokens = data_tokens(line);
        if tokens.len() < 2 {
            return Err(lines.error(no, format!("expected 'label, x, y, z', found '{line}'")));
        }
        let label: i64 = parse_token(lines, no, tokens[0], "an integer node label")?;
        let mut p = [0.0; 3];
        for (k, t) in tokens[1..].iter().take(3).enumerate() {
            p[k] = parse_finite(lines, no, t, &format!("a number for coordinate {}", k + 1))?;
        }
        let index = self.nodes.len();
        if self.node_index.insert(label, index).is_some() {
            return Err(lines.error(no, format!("node {label} is defined twice")));
        }
        self.nodes.push(p);
        self.node_labels.push(label);
        if let Some(set) = nset {
            let key = set.to_ascii_uppercase();
            self.nsets
                .entry(key)
                .or_insert_with(|| (set.to_string(), Vec::new()))
                .1
                .push(index);
        }
        Ok(())
    }

    fn element(
        &mut self,
        lines: &Lines<'_>,
        no: usize,
        tokens: &[String],
        block: usize,
        elset: Option<&str>,
    ) -> Result<(), ReadError> {
        let label: i64 = parse_token(lines, no, &tokens[0], "an integer element label")?;
        let mut nodes = Vec::with_capacity(tokens.len() - 1);
        for t in &tokens[1..] {
            let node: i64 = parse_token(lines, no, t, "an integer node label")?;
            let index = *self.node_index.get(&node).ok_or_else(|| {
                lines.error(
                    no,
                    format!("element {label} refers to node {node}, which is not defined"),
                )
            })?;
            nodes.push(index);
        }
        let b = &mut self.blocks[block];
        let r = ElementRef {
            block,
            element: b.len(),
        };
        b.connectivity.extend(nodes);
        if self.element_index.insert(label, r).is_some() {
            return Err(lines.error(no, format!("element {label} is defined twice")));
        }
        if let Some(set) = elset {
            let key = set.to_ascii_uppercase();
            self.elsets
                .entry(key)
                .or_insert_with(|| (set.to_string(), Vec::new()))
                .1
                .push(r);
        }
        Ok(())
    }

    /// Labels or set names on one set data line (`GENERATE`: start, end[, step]).
    fn set_members(
        &self,
        lines: &Lines<'_>,
        no: usize,
        line: &str,
        generate: bool,
        nodes: bool,
    ) -> Result<Vec<Member>, ReadError> {
        let tokens = data_tokens(line);
        if generate {
            if !(2..=3).contains(&tokens.len()) {
                return Err(lines.error(
                    no,
                    format!("expected 'start, end[, step]' after GENERATE, found '{line}'"),
                ));
            }
            let start: i64 = parse_token(lines, no, tokens[0], "an integer start label")?;
            let end: i64 = parse_token(lines, no, tokens[1], "an integer end label")?;
            let step: i64 = match tokens.get(2) {
                Some(t) => parse_token(lines, no, t, "an integer step")?,
                None => 1,
            };
            if step <= 0 || end < start {
                return Err(lines.error(
                    no,
                    format!("GENERATE needs start <= end and step > 0, found '{line}'"),
                ));
            }
            // Every generated label must be defined, so a range with more labels than there
            // are nodes (elements) is wrong: say so before allocating it. i128: the span of
            // two i64 labels does not fit an i64.
            let count = (i128::from(end) - i128::from(start)) / i128::from(step) + 1;
            let (defined, what) = if nodes {
                (self.node_index.len(), "nodes")
            } else {
                (self.element_index.len(), "elements")
            };
            if count > defined as i128 {
                return Err(lines.error(
                    no,
                    format!(
                        "GENERATE range of {count} labels, but only {defined} {what} are defined, \
                         found '{line}'"
                    ),
                ));
            }
            return Ok((start..=end)
                .step_by(step as usize)
                .map(Member::Label)
                .collect());
        }
        let mut members = Vec::with_capacity(tokens.len());
        for t in tokens {
            if t.is_empty() {
                continue;
            }
            if let Ok(label) = t.parse::<i64>() {
                members.push(Member::Label(label));
                continue;
            }
            let key = t.to_ascii_uppercase();
            let known = if nodes {
                self.nsets.contains_key(&key)
            } else {
                self.elsets.contains_key(&key)
            };
            if !known {
                let what = if nodes { "node" } else { "element" };
                return Err(lines.error(
                    no,
                    format!(
                        "expected a {what} label or the name of a defined {what} set, found '{t}'"
                    ),
                ));
            }
            members.push(Member::Set(key));
        }
        Ok(members)
    }

    /// `*NSET, NSET=set, ELSET=a, b`: the nodes of the listed element sets.
    fn nodes_of_elset(
        &mut self,
        lines: &Lines<'_>,
        no: usize,
        set: &str,
        elsets: &str,
    ) -> Result<(), ReadError> {
        let mut nodes = Vec::new();
        for name in elsets.split_whitespace() {
            let refs = &self
                .elsets
                .get(&name.to_ascii_uppercase())
                .ok_or_else(|| lines.error(no, format!("element set {name} is not defined")))?
                .1;
            for r in refs {
                nodes.extend_from_slice(self.blocks[r.block].element(r.element));
            }
        }
        if let Some(s) = self.nsets.get_mut(&set.to_ascii_uppercase()) {
            s.1.extend(nodes);
            // Repeated keyword lines must not grow the set without bound.
            s.1.sort_unstable();
            s.1.dedup();
        }
        Ok(())
    }

    /// Checks that no element was left with an unfinished node list.
    fn finish(&self, lines: &Lines<'_>, mode: &Mode) -> Result<(), ReadError> {
        if let Mode::Element { kind, pending, .. } = mode {
            if !pending.tokens.is_empty() {
                return Err(lines.error(
                    pending.first_line,
                    format!(
                        "expected {} node labels for a {} element, found {}",
                        kind.nodes_per_element(),
                        kind.name(),
                        pending.tokens.len() - 1
                    ),
                ));
            }
        }
        Ok(())
    }

    fn into_deck(self) -> AbaqusDeck {
        let mut mesh = Mesh {
            nodes: self.nodes,
            blocks: self.blocks,
            node_sets: BTreeMap::new(),
        };
        for (_, (name, nodes)) in self.nsets {
            mesh.insert_node_set(name, nodes);
        }
        let element_sets = self
            .elsets
            .into_values()
            .map(|(name, mut refs)| {
                refs.sort_unstable();
                refs.dedup();
                (name, refs)
            })
            .collect();
        AbaqusDeck {
            mesh,
            element_sets,
            node_labels: self.node_labels,
        }
    }
}

/// One entry of a set data line.
enum Member {
    Label(i64),
    /// Upper-case name of an already defined set.
    Set(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    const DECK: &str = "*HEADING
** a comment
*node, nset=all
1, 0, 0, 0
2, 1, 0, 0
3, 1, 1, 0
4, 0, 1, 0
5, 0, 0, 1
6, 1, 0, 1
7, 1, 1, 1
8, 0, 1, 1
9, 2, 0, 0
*ELEMENT, TYPE=C3D8R,
 ELSET=Body
10, 1, 2, 3, 4,
5, 6, 7, 8
*Element, type=T3D2, elset=bars
20, 2, 9
*NSET, NSET=BOTTOM, GENERATE
1, 4
*NSET, NSET=MIXED
bottom, 9
*ELSET, ELSET=ALLEL
BODY, 20
*MATERIAL, NAME=X
*ELASTIC
1e6, 0.3
*NSET, NSET=ODD, generate
1, 9, 2
";

    #[test]
    fn parses_nodes_blocks_and_sets() {
        let deck = parse_abaqus(DECK, "d.inp").unwrap();
        let mesh = &deck.mesh;
        assert_eq!(mesh.num_nodes(), 9);
        assert_eq!(mesh.nodes[8], [2.0, 0.0, 0.0]);
        assert_eq!(mesh.blocks.len(), 2);
        assert_eq!(mesh.blocks[0].name, "Body");
        assert_eq!(mesh.blocks[0].kind, ElementKind::Hex8);
        assert_eq!(mesh.blocks[0].connectivity, (0..8).collect::<Vec<_>>());
        assert_eq!(mesh.blocks[1].name, "bars");
        assert_eq!(mesh.blocks[1].connectivity, vec![1, 8]);
        assert_eq!(mesh.node_sets["BOTTOM"], vec![0, 1, 2, 3]);
        assert_eq!(mesh.node_sets["MIXED"], vec![0, 1, 2, 3, 8]);
        assert_eq!(mesh.node_sets["ODD"], vec![0, 2, 4, 6, 8]);
        assert_eq!(mesh.node_sets["all"].len(), 9);
        let r = |block, element| ElementRef { block, element };
        assert_eq!(deck.element_sets["ALLEL"], vec![r(0, 0), r(1, 0)]);
        assert_eq!(deck.element_sets["Body"], vec![r(0, 0)]);
        assert_eq!(deck.node_index(9), Some(8));
        mesh.validate().unwrap();
    }

    #[test]
    fn errors_name_line_and_problem() {
        let cases = [
            (
                "10, 1, 2, 3, 4,\n5, 6, 7, 8",
                "10, 1, 2, 3, 4,\n5, 6, 7, 42",
                15,
                "node 42",
            ),
            (
                "9, 2, 0, 0",
                "9, 2, zero, 0",
                12,
                "expected a number for coordinate 2, found 'zero'",
            ),
            (
                "TYPE=C3D8R",
                "TYPE=C3D15",
                13,
                "element type C3D15 is not supported",
            ),
            ("bottom, 9", "bottom, nosuch", 22, "found 'nosuch'"),
            (
                "5, 6, 7, 8\n",
                "5, 6, 7\n",
                15,
                "expected 8 node labels for a hex8 element, found 7",
            ),
            (
                "5, 6, 7, 8\n",
                "5, 6, 7, 8, 9\n",
                16,
                "expected 8 node labels",
            ),
        ];
        for (from, to, line, text) in cases {
            let bad = DECK.replace(from, to);
            let err = parse_abaqus(&bad, "d.inp").unwrap_err();
            assert_eq!(err.line(), Some(line), "{err}");
            assert!(
                err.to_string().starts_with(&format!("d.inp line {line}: ")),
                "{err}"
            );
            assert!(err.to_string().contains(text), "{err}");
        }
    }

    #[test]
    fn reads_the_sphere_compression_reference_deck() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/reference/sphere_compression/problem.inp");
        let path = path.as_path();
        if !path.exists() {
            eprintln!("skipped: {} is absent", path.display());
            return;
        }
        let deck = read_abaqus(path).unwrap();
        let mesh = &deck.mesh;
        assert_eq!(mesh.num_nodes(), 1351);
        let cell = mesh.block("CELL").unwrap();
        assert_eq!((cell.kind, cell.len()), (ElementKind::Hex8, 1000));
        assert_eq!(mesh.block("TOPPLATE").unwrap().len(), 1);
        assert_eq!(mesh.node_sets["AXIS"].len(), 11);
        assert_eq!(mesh.node_sets["AXIS"][0], deck.node_index(661).unwrap());
        assert_eq!(mesh.node_sets["EQ"], vec![deck.node_index(1271).unwrap()]);
        assert_eq!(mesh.node_sets["REFTOP"], vec![1347]);
        assert_eq!(mesh.nodes[1347], [0.0, 0.0, 16.132]);
        assert_eq!(deck.element_sets["CELL"].len(), 1000);
        assert!(!mesh.node_sets["UPPER"].is_empty() && !mesh.node_sets["LOWER"].is_empty());
        mesh.validate().unwrap();
    }
}
