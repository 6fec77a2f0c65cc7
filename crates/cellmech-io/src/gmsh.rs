//! Gmsh MSH 4.1 ASCII reader.
//!
//! Elements go into blocks named after their physical group (`$PhysicalNames`), or
//! `physical_<dim>_<tag>` for an unnamed group, or `entity_<dim>_<tag>` for an entity without
//! physical group. Physical groups of dimension 0–2 also become node sets (the nodes of their
//! elements). Node tags may be sparse; they are mapped to 0-based indices in file order.
//! Quadratic elements are reordered to the Abaqus node order used by [`Mesh`].

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use cellmech_fem::mesh::{ElementBlock, ElementKind, Mesh};

use crate::error::ReadError;
use crate::lines::{parse_finite, parse_token, Lines};

/// Reads a Gmsh MSH 4.1 ASCII file.
pub fn read_gmsh(path: &Path) -> Result<Mesh, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // Binary MSH files have an ASCII header; a lossy conversion lets the header check report
    // "binary" instead of a UTF-8 error.
    let text = String::from_utf8_lossy(&bytes);
    parse_gmsh(&text, &path.display().to_string())
}

/// Parses MSH 4.1 ASCII text; `file` names the source in error messages.
pub fn parse_gmsh(text: &str, file: &str) -> Result<Mesh, ReadError> {
    let mut lines = Lines::new(text, file);
    let mut state = GmshState::default();
    let mut seen_format = false;
    while let Some((no, line)) = lines.next_line() {
        if line.is_empty() {
            continue;
        }
        if !seen_format && line != "$MeshFormat" {
            return Err(lines.error(
                no,
                format!("expected $MeshFormat first (is this a Gmsh MSH file?), found '{line}'"),
            ));
        }
        let Some(section) = line.strip_prefix('$') else {
            return Err(lines.error(
                no,
                format!("expected a section such as $Nodes, found '{line}'"),
            ));
        };
        match section {
            "MeshFormat" => {
                read_format(&mut lines)?;
                seen_format = true;
            }
            "PhysicalNames" => read_physical_names(&mut lines, &mut state)?,
            "Entities" => read_entities(&mut lines, &mut state)?,
            "Nodes" => read_nodes(&mut lines, &mut state)?,
            "Elements" => read_elements(&mut lines, &mut state)?,
            other => skip_section(&mut lines, other, no)?,
        }
        let end = format!("$End{section}");
        let (end_no, end_line) = lines.expect_line(&end)?;
        if end_line != end {
            return Err(lines.error(end_no, format!("expected {end}, found '{end_line}'")));
        }
    }
    if !seen_format {
        return Err(lines.content_error("no $MeshFormat section: not a Gmsh MSH file"));
    }
    if !state.seen_nodes {
        return Err(lines.content_error("no $Nodes section"));
    }
    Ok(state.into_mesh())
}

#[derive(Default)]
struct GmshState {
    physical_names: HashMap<(u32, i64), String>,
    entity_physicals: HashMap<(u32, i64), Vec<i64>>,
    node_index: HashMap<u64, usize>,
    nodes: Vec<[f64; 3]>,
    seen_nodes: bool,
    blocks: Vec<ElementBlock>,
    block_index: HashMap<(String, ElementKind), usize>,
    node_sets: BTreeMap<String, Vec<usize>>,
}

impl GmshState {
    fn group_name(&self, dim: u32, tag: i64) -> String {
        self.physical_names
            .get(&(dim, tag))
            .cloned()
            .unwrap_or_else(|| format!("physical_{dim}_{tag}"))
    }

    fn into_mesh(self) -> Mesh {
        let mut mesh = Mesh {
            nodes: self.nodes,
            blocks: self.blocks,
            node_sets: BTreeMap::new(),
        };
        for (name, nodes) in self.node_sets {
            mesh.insert_node_set(name, nodes);
        }
        mesh
    }
}

fn read_format(lines: &mut Lines<'_>) -> Result<(), ReadError> {
    let (no, line) = lines.expect_line("the format line 'version file-type data-size'")?;
    let tokens: Vec<&str> = line.split_whitespace().collect();
    if tokens.len() < 3 {
        return Err(lines.error(
            no,
            format!("expected 'version file-type data-size', found '{line}'"),
        ));
    }
    if tokens[1] != "0" {
        return Err(lines.error(no, "binary MSH is not supported; save as ASCII 4.1"));
    }
    if !tokens[0].starts_with("4.1") {
        return Err(lines.error(
            no,
            format!(
                "MSH version {} is not supported; save as ASCII 4.1",
                tokens[0]
            ),
        ));
    }
    Ok(())
}

fn read_physical_names(lines: &mut Lines<'_>, state: &mut GmshState) -> Result<(), ReadError> {
    let (no, line) = lines.expect_line("the number of physical names")?;
    let count: usize = parse_token(lines, no, line, "the number of physical names")?;
    for _ in 0..count {
        let (no, line) = lines.expect_line("a physical name 'dim tag \"name\"'")?;
        let mut parts = line.splitn(3, char::is_whitespace);
        let dim: u32 = parse_token(lines, no, parts.next().unwrap_or(""), "a dimension")?;
        let tag: i64 = parse_token(lines, no, parts.next().unwrap_or(""), "a physical tag")?;
        let rest = parts.next().unwrap_or("").trim();
        let name = rest
            .strip_prefix('"')
            .and_then(|r| r.strip_suffix('"'))
            .ok_or_else(|| lines.error(no, format!("expected a quoted name, found '{rest}'")))?;
        state.physical_names.insert((dim, tag), name.to_string());
    }
    Ok(())
}

fn read_entities(lines: &mut Lines<'_>, state: &mut GmshState) -> Result<(), ReadError> {
    let (no, line) = lines.expect_line("the entity counts")?;
    let counts = ints(lines, no, line, 4, "4 entity counts")?;
    for dim in 0..4u32 {
        for _ in 0..counts[dim as usize] {
            let (no, line) = lines.expect_line("an entity line")?;
            let tokens: Vec<&str> = line.split_whitespace().collect();
            // Points: tag x y z; others: tag minX minY minZ maxX maxY maxZ.
            let first_phys = if dim == 0 { 4 } else { 7 };
            if tokens.len() <= first_phys {
                return Err(lines.error(
                    no,
                    format!(
                        "expected at least {} values for an entity of dimension {dim}, found {}",
                        first_phys + 1,
                        tokens.len()
                    ),
                ));
            }
            let tag: i64 = parse_token(lines, no, tokens[0], "an entity tag")?;
            let n: usize = parse_token(lines, no, tokens[first_phys], "a physical tag count")?;
            // n comes from the file: compare without overflow.
            if tokens.len() - first_phys - 1 < n {
                return Err(lines.error(
                    no,
                    format!(
                        "expected {n} physical tags, found {}",
                        tokens.len() - first_phys - 1
                    ),
                ));
            }
            let mut tags = Vec::with_capacity(n);
            for t in &tokens[first_phys + 1..first_phys + 1 + n] {
                // Gmsh writes negative tags for orientation; the group is the absolute value.
                tags.push(parse_token::<i64>(lines, no, t, "a physical tag")?.abs());
            }
            state.entity_physicals.insert((dim, tag), tags);
        }
    }
    Ok(())
}

fn read_nodes(lines: &mut Lines<'_>, state: &mut GmshState) -> Result<(), ReadError> {
    let (no, line) = lines.expect_line("the node header")?;
    let header = ints(
        lines,
        no,
        line,
        4,
        "4 values 'numEntityBlocks numNodes minTag maxTag'",
    )?;
    // The count comes from the file: reserve no more than the lines left can hold.
    state
        .nodes
        .reserve((header[1] as usize).min(lines.remaining()));
    for _ in 0..header[0] {
        let (no, line) = lines.expect_line("a node block header")?;
        let block = ints(
            lines,
            no,
            line,
            4,
            "4 values 'entityDim entityTag parametric numNodes'",
        )?;
        let count = block[3] as usize;
        let first = state.nodes.len();
        for i in 0..count {
            let (no, line) = lines.expect_line("a node tag")?;
            let tag: u64 = parse_token(lines, no, line, "a node tag")?;
            if state.node_index.insert(tag, first + i).is_some() {
                return Err(lines.error(no, format!("node tag {tag} is defined twice")));
            }
        }
        for _ in 0..count {
            let (no, line) = lines.expect_line("node coordinates")?;
            let tokens: Vec<&str> = line.split_whitespace().collect();
            if tokens.len() < 3 {
                return Err(lines.error(
                    no,
                    format!("expected 3 coordinates, found {}", tokens.len()),
                ));
            }
            let mut p = [0.0; 3];
            for k in 0..3 {
                p[k] = parse_finite(lines, no, tokens[k], "a coordinate")?;
            }
            state.nodes.push(p);
        }
    }
    if state.nodes.len() != header[1] as usize {
        return Err(lines.error(
            no,
            format!(
                "the header announces {} nodes, the blocks hold {}",
                header[1],
                state.nodes.len()
            ),
        ));
    }
    state.seen_nodes = true;
    Ok(())
}

/// Element kind and the permutation from Gmsh to Abaqus node order (`None` = identity).
fn element_kind(gmsh_type: i64) -> Option<(ElementKind, Option<&'static [usize]>)> {
    const TET10: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8];
    const HEX20: [usize; 20] = [
        0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15,
    ];
    Some(match gmsh_type {
        1 => (ElementKind::Line2, None),
        2 => (ElementKind::Tri3, None),
        3 => (ElementKind::Quad4, None),
        4 => (ElementKind::Tet4, None),
        5 => (ElementKind::Hex8, None),
        6 => (ElementKind::Wedge6, None),
        11 => (ElementKind::Tet10, Some(&TET10)),
        17 => (ElementKind::Hex20, Some(&HEX20)),
        _ => return None,
    })
}

fn read_elements(lines: &mut Lines<'_>, state: &mut GmshState) -> Result<(), ReadError> {
    let (no, line) = lines.expect_line("the element header")?;
    let header = ints(
        lines,
        no,
        line,
        4,
        "4 values 'numEntityBlocks numElements minTag maxTag'",
    )?;
    for _ in 0..header[0] {
        let (no, line) = lines.expect_line("an element block header")?;
        let block = ints(
            lines,
            no,
            line,
            4,
            "4 values 'entityDim entityTag elementType num'",
        )?;
        let (dim, tag, gmsh_type, count) =
            (block[0] as u32, block[1] as i64, block[2] as i64, block[3]);
        let physicals = state
            .entity_physicals
            .get(&(dim, tag))
            .cloned()
            .unwrap_or_default();
        let set_names: Vec<String> = if dim <= 2 {
            physicals
                .iter()
                .map(|&p| state.group_name(dim, p))
                .collect()
        } else {
            Vec::new()
        };
        let (kind, perm, npe) = if gmsh_type == 15 {
            (None, None, 1)
        } else {
            let (kind, perm) = element_kind(gmsh_type).ok_or_else(|| {
                lines.error(
                    no,
                    format!(
                        "Gmsh element type {gmsh_type} is not supported (supported: 1 line2, \
                         2 tri3, 3 quad4, 4 tet4, 5 hex8, 6 wedge6, 11 tet10, 17 hex20, 15 point)"
                    ),
                )
            })?;
            (Some(kind), perm, kind.nodes_per_element())
        };
        let block_slot = kind.map(|kind| {
            let name = match physicals.first() {
                Some(&p) => state.group_name(dim, p),
                None => format!("entity_{dim}_{tag}"),
            };
            let next = state.blocks.len();
            let slot = *state
                .block_index
                .entry((name.clone(), kind))
                .or_insert(next);
            if slot == next {
                state.blocks.push(ElementBlock {
                    name,
                    kind,
                    connectivity: Vec::new(),
                });
            }
            slot
        });
        let mut element = Vec::with_capacity(npe);
        for _ in 0..count {
            let (no, line) = lines.expect_line("an element line")?;
            let tokens: Vec<&str> = line.split_whitespace().collect();
            if tokens.len() != npe + 1 {
                return Err(lines.error(
                    no,
                    format!(
                        "expected {npe} node tags, found {}",
                        tokens.len().saturating_sub(1)
                    ),
                ));
            }
            element.clear();
            for t in &tokens[1..] {
                let node_tag: u64 = parse_token(lines, no, t, "a node tag")?;
                let index = *state.node_index.get(&node_tag).ok_or_else(|| {
                    lines.error(
                        no,
                        format!("element refers to node tag {node_tag}, which is not defined"),
                    )
                })?;
                element.push(index);
            }
            for name in &set_names {
                state
                    .node_sets
                    .entry(name.clone())
                    .or_default()
                    .extend(&element);
            }
            if let Some(slot) = block_slot {
                let conn = &mut state.blocks[slot].connectivity;
                match perm {
                    Some(p) => conn.extend(p.iter().map(|&k| element[k])),
                    None => conn.extend(&element),
                }
            }
        }
    }
    Ok(())
}

fn skip_section(lines: &mut Lines<'_>, name: &str, start: usize) -> Result<(), ReadError> {
    let end = format!("$End{name}");
    while let Some((_, line)) = lines.peek() {
        if line == end {
            return Ok(());
        }
        lines.next_line();
    }
    Err(lines.error(start, format!("section ${name} has no {end}")))
}

/// Parses exactly `n` leading integers of a line (extra tokens are an error).
fn ints(
    lines: &Lines<'_>,
    no: usize,
    line: &str,
    n: usize,
    what: &str,
) -> Result<Vec<u64>, ReadError> {
    let tokens: Vec<&str> = line.split_whitespace().collect();
    if tokens.len() != n {
        return Err(lines.error(no, format!("expected {what}, found '{line}'")));
    }
    tokens
        .iter()
        .map(|t| parse_token(lines, no, t, "a non-negative integer"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One unit cube (hex8) in volume 1 "cell", its bottom face (quad4) in surface 1 "bottom",
    /// a corner point in an unnamed physical point group 7; sparse node tags 10..80.
    const CUBE: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
2 1 "bottom"
3 2 "cell"
$EndPhysicalNames
$Entities
1 0 1 1
1 0 0 0 1 7
1 0 0 0 1 1 0 1 1 0
1 0 0 0 1 1 1 1 2 1 1
$EndEntities
$Nodes
3 8 10 80
0 1 0 1
10
0 0 0
2 1 0 3
20
30
40
1 0 0
1 1 0
0 1 0
3 1 0 4
50
60
70
80
0 0 1
1 0 1
1 1 1
0 1 1
$EndNodes
$Comments
anything here is skipped
$EndComments
$Elements
3 3 1 3
0 1 15 1
1 10
2 1 3 1
2 10 20 30 40
3 1 5 1
3 10 20 30 40 50 60 70 80
$EndElements
"#;

    #[test]
    fn reads_blocks_node_sets_and_sparse_tags() {
        let mesh = parse_gmsh(CUBE, "cube.msh").unwrap();
        assert_eq!(mesh.num_nodes(), 8);
        assert_eq!(mesh.nodes[0], [0.0, 0.0, 0.0]);
        assert_eq!(mesh.nodes[2], [1.0, 1.0, 0.0]);
        assert_eq!(mesh.nodes[7], [0.0, 1.0, 1.0]);
        assert_eq!(mesh.blocks.len(), 2);
        let bottom = mesh.block("bottom").unwrap();
        assert_eq!(bottom.kind, ElementKind::Quad4);
        assert_eq!(bottom.connectivity, vec![0, 1, 2, 3]);
        let cell = mesh.block("cell").unwrap();
        assert_eq!(cell.kind, ElementKind::Hex8);
        assert_eq!(cell.connectivity, (0..8).collect::<Vec<_>>());
        assert_eq!(mesh.node_sets["bottom"], vec![0, 1, 2, 3]);
        assert_eq!(mesh.node_sets["physical_0_7"], vec![0]);
        assert!(
            !mesh.node_sets.contains_key("cell"),
            "volumes give no node set"
        );
        mesh.validate().unwrap();
    }

    #[test]
    fn wrong_node_count_names_the_line() {
        let bad = CUBE.replace("3 10 20 30 40 50 60 70 80", "3 10 20 30 40 50 60 70");
        let err = parse_gmsh(&bad, "mesh.msh").unwrap_err();
        assert_eq!(err.line(), Some(47));
        assert_eq!(
            err.to_string(),
            "mesh.msh line 47: expected 8 node tags, found 7"
        );
    }

    #[test]
    fn quad_with_three_nodes_is_reported() {
        let bad = CUBE.replace("2 10 20 30 40", "2 10 20 30");
        let err = parse_gmsh(&bad, "mesh.msh").unwrap_err();
        assert_eq!(
            err.to_string(),
            "mesh.msh line 45: expected 4 node tags, found 3"
        );
    }

    #[test]
    fn undefined_node_and_unknown_type_are_errors() {
        let bad = CUBE.replace("2 10 20 30 40", "2 10 20 30 99");
        let err = parse_gmsh(&bad, "m.msh").unwrap_err().to_string();
        assert!(
            err.contains("line 45") && err.contains("node tag 99"),
            "{err}"
        );
        let bad = CUBE.replace("2 1 3 1", "2 1 8 1");
        let err = parse_gmsh(&bad, "m.msh").unwrap_err().to_string();
        assert!(err.contains("line 44") && err.contains("type 8"), "{err}");
        let bad = CUBE.replace("1 0 0\n1 1 0", "1 x 0\n1 1 0");
        let err = parse_gmsh(&bad, "m.msh").unwrap_err().to_string();
        assert_eq!(err, "m.msh line 24: expected a coordinate, found 'x'");
    }

    #[test]
    fn binary_and_old_versions_are_refused() {
        let err = parse_gmsh(&CUBE.replace("4.1 0 8", "4.1 1 8"), "b.msh").unwrap_err();
        assert_eq!(
            err.to_string(),
            "b.msh line 2: binary MSH is not supported; save as ASCII 4.1"
        );
        let err = parse_gmsh(&CUBE.replace("4.1 0 8", "2.2 0 8"), "o.msh").unwrap_err();
        assert!(err.to_string().contains("version 2.2"), "{err}");
        let err = parse_gmsh("hello\n", "x.msh").unwrap_err();
        assert!(err.to_string().contains("$MeshFormat"), "{err}");
    }

    #[test]
    fn unnamed_entities_and_quadratic_reordering() {
        // A tet10 without physical group: block entity_3_4; Gmsh's nodes 8 and 9 swap to
        // reach the Abaqus order (edge 1-3 before edge 2-3).
        let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 10 1 10\n3 4 0 10\n\
                    1\n2\n3\n4\n5\n6\n7\n8\n9\n10\n"
            .to_string()
            + &"0 0 0\n".repeat(10)
            + "$EndNodes\n$Elements\n1 1 1 1\n3 4 11 1\n1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n";
        let mesh = parse_gmsh(&text, "t.msh").unwrap();
        let block = mesh.block("entity_3_4").unwrap();
        assert_eq!(block.kind, ElementKind::Tet10);
        assert_eq!(block.connectivity, vec![0, 1, 2, 3, 4, 5, 6, 7, 9, 8]);
    }

    #[test]
    fn hex20_permutation_maps_edges_to_abaqus_order() {
        // Gmsh hex20 edge nodes by vertex pair; Abaqus expects (0,1),(1,2),(2,3),(3,0),
        // (4,5),(5,6),(6,7),(7,4),(0,4),(1,5),(2,6),(3,7).
        let gmsh_edges = [
            (0, 1),
            (0, 3),
            (0, 4),
            (1, 2),
            (1, 5),
            (2, 3),
            (2, 6),
            (3, 7),
            (4, 5),
            (4, 7),
            (5, 6),
            (6, 7),
        ];
        let abaqus_edges = [
            (0, 1),
            (1, 2),
            (2, 3),
            (0, 3),
            (4, 5),
            (5, 6),
            (6, 7),
            (4, 7),
            (0, 4),
            (1, 5),
            (2, 6),
            (3, 7),
        ];
        let Some((ElementKind::Hex20, Some(perm))) = element_kind(17) else {
            panic!("hex20 must carry a permutation");
        };
        for (i, edge) in abaqus_edges.iter().enumerate() {
            assert_eq!(
                gmsh_edges[perm[8 + i] - 8],
                *edge,
                "Abaqus edge node {}",
                8 + i
            );
        }
    }

    #[test]
    fn reads_a_file_written_by_meshio() {
        // tests/data/meshio_two_hexes.msh: written by meshio 5.3.5 (no $Entities section, so
        // the physical group cannot be attached and the block is named after the entity).
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/meshio_two_hexes.msh");
        let mesh = read_gmsh(&path).unwrap();
        assert_eq!(mesh.num_nodes(), 12);
        assert_eq!(mesh.nodes[11], [2.0, 1.0, 1.0]);
        let block = mesh.block("entity_3_1").unwrap();
        assert_eq!(block.kind, ElementKind::Hex8);
        assert_eq!(block.element(1), &[1, 2, 5, 4, 7, 8, 11, 10]);
        let missing = read_gmsh(Path::new("/nonexistent/x.msh")).unwrap_err();
        assert!(
            missing
                .to_string()
                .starts_with("cannot read /nonexistent/x.msh"),
            "{missing}"
        );
    }
}
