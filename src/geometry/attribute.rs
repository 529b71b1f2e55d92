//! Per-vertex and per-face data that mesh files carry beside positions,
//! normals and uvs (vertex colours, face weights), named as Mitsuba 3
//! names them: `vertex_<prefix>` / `face_<prefix>`, with `r g b` (or
//! `red green blue`) as `<kind>_color`. `mesh_attribute` textures read
//! them.

use crate::color::Rgb;

/// One attribute of a mesh: one or three channels per vertex or per
/// triangle (a polygon's value repeated on each of its triangles).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// `vertex_...` or `face_...`.
    pub name: String,
    pub per_vertex: bool,
    /// 1 or 3 (a single channel is stored in all three).
    pub channels: usize,
    pub values: Vec<Rgb>,
}

/// Groups a record's field names into attributes, as Mitsuba's PLY reader
/// does: `r g b` (or `red green blue`) is `color`; otherwise consecutive
/// fields `<prefix>_<c>` whose suffixes run through one of x y z w, r g b
/// a, 0 1 2 3 or 1 2 3 4 form `<prefix>`, kept if they are 1 or 3.
/// `reserved` fields (positions, normals, uvs, lists) take no part.
/// Returns (name without the kind, field indices).
pub fn group_fields(names: &[&str], reserved: &[bool]) -> Vec<(String, Vec<usize>)> {
    let find = |n: &str| names.iter().position(|x| *x == n).filter(|&i| !reserved[i]);
    let mut groups = Vec::new();
    let mut used = reserved.to_vec();
    for rgb in [["r", "g", "b"], ["red", "green", "blue"]] {
        if let (Some(r), Some(g), Some(b)) = (find(rgb[0]), find(rgb[1]), find(rgb[2])) {
            groups.push(("color".to_string(), vec![r, g, b]));
            for i in [r, g, b] {
                used[i] = true;
            }
            break;
        }
    }
    for extra in ["a", "alpha"] {
        if let Some(i) = find(extra) {
            used[i] = true;
        }
    }
    const LEVELS: [&str; 4] = ["xr01", "yg12", "zb23", "wa34"];
    let split = |n: &str| -> Option<(String, char)> {
        let (prefix, suffix) = n.rsplit_once('_')?;
        let mut cs = suffix.chars();
        let c = cs.next()?;
        (cs.next().is_none() && !prefix.is_empty()).then(|| (prefix.to_string(), c))
    };
    let mut i = 0;
    while i < names.len() {
        let Some((prefix, c)) = split(names[i]).filter(|_| !used[i]) else {
            i += 1;
            continue;
        };
        let Some(category) = LEVELS[0].find(c) else {
            i += 1;
            continue;
        };
        let mut fields = vec![i];
        let mut j = i + 1;
        while j < names.len() && fields.len() < 4 && !used[j] {
            match split(names[j]) {
                Some((p, c))
                    if p == prefix && LEVELS[fields.len()].chars().nth(category) == Some(c) =>
                {
                    fields.push(j);
                    j += 1;
                }
                _ => break,
            }
        }
        if fields.len() == 1 || fields.len() == 3 {
            groups.push((prefix, fields));
        }
        i = j;
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_group_as_mitsuba_groups_them() {
        let names = [
            "x", "y", "z", "color_0", "color_1", "color_2", "weight_0", "red", "green", "blue",
            "n_x", "n_y",
        ];
        let mut reserved = vec![false; names.len()];
        reserved[..3].fill(true);
        let g = group_fields(&names, &reserved);
        assert_eq!(
            g,
            vec![
                ("color".to_string(), vec![7, 8, 9]),
                ("color".to_string(), vec![3, 4, 5]),
                ("weight".to_string(), vec![6]),
            ]
        );
        // Two fields make no attribute; a 1-based suffix runs 1 2 3.
        let g = group_fields(&["a_1", "a_2", "a_3", "b_x", "b_y"], &[false; 5]);
        assert_eq!(g, vec![("a".to_string(), vec![0, 1, 2])]);
    }
}
