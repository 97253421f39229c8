//! Minimum cuts: the maximum flow between two nodes of an undirected network with real
//! capacities, and the two sides of its minimum cuts (topology only; [`tunnel_labels`]
//! builds the network from the cells of two groups and their portals' areas).
//!
//! The flow is Dinic's (1970): per phase, a breadth-first search levels the residual graph
//! from the source up to the sink's level, then a depth-first search with a current-edge
//! pointer per node saturates every shortest augmenting path (a blocking flow). It replaces Edmonds–Karp, which ran one
//! breadth-first search of the whole network per augmenting path: on a 500k-cell outdoor
//! level (Nexuiz `cyberparcour01`) the boundary moves took over a minute.
//!
//! What the caller reads is not the flow but the cut's sides: the nodes the source reaches
//! in the residual graph and those that reach the sink. For any maximum flow these are the
//! same sets (the source side of the least minimum cut and the sink side of the largest
//! one, Ford & Fulkerson 1962), so the algorithm that finds the flow does not change them
//! (`dinic_cuts_equal_edmonds_karp_cuts`, with capacities whose sums are exact).
//!
//! [`tunnel_labels`]: super::clearance::tunnel_labels

/// A flow network: directed edges in pairs (edge `e ^ 1` is `e` reversed, with its own
/// residual capacity), each node's edges as a compressed row (`adj[start[u]..start[u + 1]]`).
pub(crate) struct FlowNet {
    start: Vec<u32>,
    adj: Vec<u32>,
    to: Vec<u32>,
    cap: Vec<f64>,
}

impl FlowNet {
    /// The network of `nodes` nodes with undirected edges `(u, v, capacity)`, each as two
    /// directed edges of that capacity, in the order given (a node's row keeps that order).
    pub(crate) fn new(nodes: usize, edges: impl IntoIterator<Item = (u32, u32, f64)>) -> Self {
        let (mut from, mut to, mut cap) = (Vec::new(), Vec::new(), Vec::new());
        for (u, v, c) in edges {
            for (a, b) in [(u, v), (v, u)] {
                from.push(a);
                to.push(b);
                cap.push(c);
            }
        }
        let mut start = vec![0u32; nodes + 1];
        for &u in &from {
            start[u as usize + 1] += 1;
        }
        for u in 0..nodes {
            start[u + 1] += start[u];
        }
        let mut fill = start.clone();
        let mut adj = vec![0u32; from.len()];
        for (e, &u) in from.iter().enumerate() {
            adj[fill[u as usize] as usize] = e as u32;
            fill[u as usize] += 1;
        }
        FlowNet { start, adj, to, cap }
    }

    fn nodes(&self) -> usize {
        self.start.len() - 1
    }

    fn row(&self, u: u32) -> &[u32] {
        &self.adj[self.start[u as usize] as usize..self.start[u as usize + 1] as usize]
    }

    /// Saturates the network from `source` to `sink` (Dinic) and returns the cut's sides:
    /// `(reach, to_sink)`, the nodes reachable from `source` in the residual graph and the
    /// nodes from which `sink` is reachable. Both are the same for every maximum flow.
    pub(crate) fn min_cut(&mut self, source: u32, sink: u32) -> (Vec<bool>, Vec<bool>) {
        let n = self.nodes();
        let mut level = vec![u32::MAX; n];
        let mut next = vec![0u32; n];
        let mut queue = std::collections::VecDeque::new();
        let mut path: Vec<u32> = Vec::new();
        loop {
            // Level the residual graph from the source, up to the sink's level: a node at
            // or beyond it lies on no shortest path (the last search, which does not reach
            // the sink, levels every node the source reaches).
            level.iter_mut().for_each(|l| *l = u32::MAX);
            level[source as usize] = 0;
            queue.clear();
            queue.push_back(source);
            while let Some(u) = queue.pop_front() {
                if level[u as usize] >= level[sink as usize] {
                    break;
                }
                for &e in self.row(u) {
                    let v = self.to[e as usize];
                    if level[v as usize] == u32::MAX && self.cap[e as usize] > 0.0 {
                        level[v as usize] = level[u as usize] + 1;
                        queue.push_back(v);
                    }
                }
            }
            if level[sink as usize] == u32::MAX {
                break;
            }
            // A blocking flow: depth first along edges one level down the path, each node's
            // current edge advancing past edges that are saturated or lead to dead ends.
            next.copy_from_slice(&self.start[..n]);
            path.clear();
            let mut u = source;
            loop {
                if u == sink {
                    let bottleneck = path.iter().map(|&e| self.cap[e as usize]).fold(f64::INFINITY, f64::min);
                    // Augment, then back up to the tail of the first saturated edge.
                    let mut back = path.len();
                    for (k, &e) in path.iter().enumerate() {
                        self.cap[e as usize] -= bottleneck;
                        self.cap[e as usize ^ 1] += bottleneck;
                        if back == path.len() && self.cap[e as usize] <= 0.0 {
                            back = k;
                        }
                    }
                    path.truncate(back);
                    u = path.last().map_or(source, |&e| self.to[e as usize]);
                    continue;
                }
                let end = self.start[u as usize + 1];
                let mut advanced = false;
                while next[u as usize] < end {
                    let e = self.adj[next[u as usize] as usize];
                    let v = self.to[e as usize];
                    if self.cap[e as usize] > 0.0 && level[v as usize] == level[u as usize].wrapping_add(1) {
                        path.push(e);
                        u = v;
                        advanced = true;
                        break;
                    }
                    next[u as usize] += 1;
                }
                if advanced {
                    continue;
                }
                // A dead end: no path to the sink through `u` in this phase.
                level[u as usize] = u32::MAX;
                match path.pop() {
                    None => break,
                    Some(e) => {
                        u = self.to[e as usize ^ 1];
                        next[u as usize] += 1;
                    }
                }
            }
        }
        let reach: Vec<bool> = level.iter().map(|&l| l != u32::MAX).collect();
        (reach, self.sink_side(sink))
    }

    /// The nodes from which `sink` is reachable in the residual graph: edge `e: v -> u`
    /// read backwards, its reverse `u -> v` has residual capacity `cap[e ^ 1]`.
    fn sink_side(&self, sink: u32) -> Vec<bool> {
        let mut to_sink = vec![false; self.nodes()];
        to_sink[sink as usize] = true;
        let mut stack = vec![sink];
        while let Some(v) = stack.pop() {
            for &e in self.row(v) {
                let u = self.to[e as usize];
                if !to_sink[u as usize] && self.cap[e as usize ^ 1] > 0.0 {
                    to_sink[u as usize] = true;
                    stack.push(u);
                }
            }
        }
        to_sink
    }

    /// Edmonds–Karp (one breadth-first search per augmenting path): the reference
    /// [`min_cut`](Self::min_cut) is tested against.
    #[cfg(test)]
    fn min_cut_edmonds_karp(&mut self, source: u32, sink: u32) -> (Vec<bool>, Vec<bool>) {
        let n = self.nodes();
        let mut prev = vec![u32::MAX; n];
        let mut queue = std::collections::VecDeque::new();
        let reach = loop {
            prev.iter_mut().for_each(|p| *p = u32::MAX);
            let mut seen = vec![false; n];
            seen[source as usize] = true;
            queue.clear();
            queue.push_back(source);
            while let Some(u) = queue.pop_front() {
                if u == sink {
                    break;
                }
                for &e in self.row(u) {
                    let v = self.to[e as usize];
                    if !seen[v as usize] && self.cap[e as usize] > 0.0 {
                        seen[v as usize] = true;
                        prev[v as usize] = e;
                        queue.push_back(v);
                    }
                }
            }
            if !seen[sink as usize] {
                break seen;
            }
            let mut bottleneck = f64::INFINITY;
            let mut v = sink;
            while v != source {
                let e = prev[v as usize] as usize;
                bottleneck = bottleneck.min(self.cap[e]);
                v = self.to[e ^ 1];
            }
            let mut v = sink;
            while v != source {
                let e = prev[v as usize] as usize;
                self.cap[e] -= bottleneck;
                self.cap[e ^ 1] += bottleneck;
                v = self.to[e ^ 1];
            }
        };
        (reach, self.sink_side(sink))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    /// On random networks (sparse and dense, with ties: capacities are small integers,
    /// whose sums are exact in f64, so the residual graphs are exact), Dinic's cut sides
    /// equal Edmonds–Karp's.
    #[test]
    fn dinic_cuts_equal_edmonds_karp_cuts() {
        let mut rng = SplitMix64(7);
        let mut nontrivial = 0;
        for round in 0..400 {
            let n = 2 + rng.below(40);
            let m = rng.below(4 * n + 1);
            let edges: Vec<(u32, u32, f64)> = (0..m)
                .map(|_| {
                    let u = rng.below(n) as u32;
                    let v = rng.below(n) as u32;
                    (u, v, (1 + rng.below(5)) as f64)
                })
                .filter(|&(u, v, _)| u != v)
                .collect();
            let mut a = FlowNet::new(n, edges.iter().copied());
            let mut b = FlowNet::new(n, edges.iter().copied());
            let (ra, sa) = a.min_cut(0, 1);
            let (rb, sb) = b.min_cut_edmonds_karp(0, 1);
            assert_eq!(ra, rb, "round {round}: source sides");
            assert_eq!(sa, sb, "round {round}: sink sides");
            assert!(!(ra[1] || sa[0]), "round {round}: a cut separates the terminals");
            nontrivial += (ra.iter().filter(|&&x| x).count() > 1 && sa.iter().filter(|&&x| x).count() > 1) as usize;
        }
        assert!(nontrivial > 50, "{nontrivial} networks with flow through both sides");
    }

    /// A ladder: two parallel paths joined by rungs, the least cut in the middle; Dinic's
    /// flow value (the capacity across the cut) is the cut's capacity.
    #[test]
    fn the_cut_of_a_ladder_is_its_narrowest_rungless_section() {
        // 0 = source, 1 = sink; a path 0-2-3-4-1 of capacities 5, 5, 1, 5 and a second
        // 0-5-6-7-1 of 5, 2, 5, 5, rungs 2-5, 3-6, 4-7 of capacity 10.
        let edges = [
            (0, 2, 5.0),
            (2, 3, 5.0),
            (3, 4, 1.0),
            (4, 1, 5.0),
            (0, 5, 5.0),
            (5, 6, 2.0),
            (6, 7, 5.0),
            (7, 1, 5.0),
            (2, 5, 10.0),
            (3, 6, 10.0),
            (4, 7, 10.0),
        ];
        let mut net = FlowNet::new(8, edges);
        let (reach, to_sink) = net.min_cut(0, 1);
        // The least cut: {3-4, 6-7} is 1 + 5 = 6; {2-3, 5-6} is 5 + 2 = 7; {3-4, 5-6}
        // crosses rung 3-6 (10). The source side is {0, 2, 3, 5, 6}.
        let side: Vec<u32> = (0..8).filter(|&u| reach[u as usize]).collect();
        assert_eq!(side, vec![0, 2, 3, 5, 6]);
        let sink: Vec<u32> = (0..8).filter(|&u| to_sink[u as usize]).collect();
        assert_eq!(sink, vec![1, 4, 7]);
    }
}
