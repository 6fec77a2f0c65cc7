//! Greedy element colouring: elements of one colour share no DOF, so they can be scattered
//! into the global arrays in parallel without locks.

/// Colours elements given their DOF lists (`dofs[offsets[e]..offsets[e+1]]`).
/// Returns the element indices grouped by colour.
pub fn color_elements(num_dofs: usize, offsets: &[usize], dofs: &[u32]) -> Vec<Vec<u32>> {
    let num_elements = offsets.len() - 1;
    let mut taken: Vec<Vec<bool>> = Vec::new();
    let mut colors: Vec<Vec<u32>> = Vec::new();
    for e in 0..num_elements {
        let element_dofs = &dofs[offsets[e]..offsets[e + 1]];
        let free_color = taken
            .iter()
            .position(|t| element_dofs.iter().all(|&d| !t[d as usize]));
        let c = free_color.unwrap_or_else(|| {
            taken.push(vec![false; num_dofs]);
            colors.push(Vec::new());
            taken.len() - 1
        });
        for &d in element_dofs {
            taken[c][d as usize] = true;
        }
        colors[c].push(e as u32);
    }
    colors
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colored_elements_never_share_a_dof() {
        // A chain of 2-DOF elements: e couples DOFs e and e+1.
        let offsets: Vec<usize> = (0..=10).map(|e| 2 * e).collect();
        let dofs: Vec<u32> = (0..10u32).flat_map(|e| [e, e + 1]).collect();
        let colors = color_elements(11, &offsets, &dofs);
        assert_eq!(colors.len(), 2);
        for color in &colors {
            let mut seen = vec![false; 11];
            for &e in color {
                for &d in &dofs[offsets[e as usize]..offsets[e as usize + 1]] {
                    assert!(!seen[d as usize]);
                    seen[d as usize] = true;
                }
            }
        }
        assert_eq!(colors.iter().map(Vec::len).sum::<usize>(), 10);
    }
}
