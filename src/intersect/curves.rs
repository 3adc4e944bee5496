//! Chaining oriented segments into polylines (intersection curves, silhouette contours).

/// A polyline through nodes (hits of an [`Intersections`](super::Intersections), or points of a
/// [`Silhouette`](super::Silhouette)), following the orientation of its segments.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Curve {
    /// Node indices in order. A closed curve lists each node once (the last node joins the
    /// first); an open one has `segments.len() + 1` nodes.
    pub nodes: Vec<u32>,
    /// Segment indices in order (segment `k` joins `nodes[k]` and `nodes[k + 1]`, cyclically
    /// for a closed curve).
    pub segments: Vec<u32>,
    /// True for a closed loop.
    pub closed: bool,
}

/// Chains segments `from -> to` over `node_count` nodes. Nodes with exactly one incoming and one
/// outgoing segment are interior to a curve; every other node (open end, branch point of a
/// non-manifold input) ends the curves through it. Deterministic: curves come in the order of
/// their first segment, open curves first.
pub(crate) fn chain(node_count: usize, segments: &[[u32; 2]]) -> Vec<Curve> {
    let (mut incoming, mut outgoing) = (vec![0u32; node_count], vec![0u32; node_count]);
    // Outgoing segments of each node, in segment order (CSR).
    let mut offsets = vec![0usize; node_count + 1];
    for s in segments {
        outgoing[s[0] as usize] += 1;
        incoming[s[1] as usize] += 1;
        offsets[s[0] as usize + 1] += 1;
    }
    for i in 0..node_count {
        offsets[i + 1] += offsets[i];
    }
    let mut out_list = vec![0u32; segments.len()];
    let mut fill = offsets.clone();
    for (k, s) in segments.iter().enumerate() {
        out_list[fill[s[0] as usize]] = k as u32;
        fill[s[0] as usize] += 1;
    }
    let regular = |n: u32| incoming[n as usize] == 1 && outgoing[n as usize] == 1;
    let next_of = |n: u32| out_list[offsets[n as usize]];

    let mut visited = vec![false; segments.len()];
    let mut curves = Vec::new();
    for k in 0..segments.len() {
        if !visited[k] && !regular(segments[k][0]) {
            curves.push(walk(
                k as u32,
                segments,
                &mut visited,
                &regular,
                &next_of,
                false,
            ));
        }
    }
    for k in 0..segments.len() {
        if !visited[k] {
            curves.push(walk(
                k as u32,
                segments,
                &mut visited,
                &regular,
                &next_of,
                true,
            ));
        }
    }
    curves
}

fn walk(
    first: u32,
    segments: &[[u32; 2]],
    visited: &mut [bool],
    regular: &impl Fn(u32) -> bool,
    next_of: &impl Fn(u32) -> u32,
    cycle: bool,
) -> Curve {
    let mut curve = Curve {
        nodes: vec![segments[first as usize][0]],
        segments: Vec::new(),
        closed: false,
    };
    let mut s = first;
    loop {
        visited[s as usize] = true;
        curve.segments.push(s);
        let to = segments[s as usize][1];
        if !regular(to) {
            curve.nodes.push(to);
            return curve;
        }
        let next = next_of(to);
        if visited[next as usize] {
            // Back at the start of a cycle.
            curve.closed = cycle && next == first;
            if !curve.closed {
                curve.nodes.push(to);
            }
            return curve;
        }
        curve.nodes.push(to);
        s = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loop_and_open_chain() {
        // Loop 0 -> 1 -> 2 -> 0 and chain 3 -> 4 -> 5, segments shuffled.
        let segs = [[4, 5], [1, 2], [3, 4], [0, 1], [2, 0]];
        let curves = chain(6, &segs);
        assert_eq!(curves.len(), 2);
        assert_eq!(curves[0].nodes, vec![3, 4, 5]);
        assert!(!curves[0].closed);
        assert_eq!(curves[1].nodes, vec![1, 2, 0]);
        assert_eq!(curves[1].segments, vec![1, 4, 3]);
        assert!(curves[1].closed);
    }

    #[test]
    fn branch_point_ends_curves() {
        // Node 0 has two outgoing segments.
        let segs = [[0, 1], [0, 2], [1, 3]];
        let curves = chain(4, &segs);
        assert_eq!(curves.len(), 2);
        assert!(curves.iter().all(|c| !c.closed));
        assert_eq!(curves[0].nodes, vec![0, 1, 3]);
    }
}
