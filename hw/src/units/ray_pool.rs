//! The ray pool (`job_source = "bundle"`): each CTU's list of remaining rays, which its
//! descriptors name by position. Two lists per CTU, written alternately at joins: a join
//! writes the list no live descriptor names (every descriptor of the subshell that joins is
//! back; the next subshell's, with overlapped joins, name the other list), so a ray buffer
//! expanding a descriptor — in any cluster, in any tick order — reads a list that does not
//! change under it. The model keeps ids only; a split moving ray ids to another cluster
//! charges their words on the inter-cluster link.

/// One CTU's two lists of (slot, global ray id).
#[derive(Clone, Debug, Default)]
pub struct RayList {
    pub lists: [Vec<(u32, u32)>; 2],
}

impl RayList {
    /// The lists of a sector of `rays` (global ids, ascending): list 0 holds every ray, list
    /// 1 is empty; both have room for the sector (no allocation at a join).
    pub fn new(rays: &[u32]) -> Self {
        let mut first = Vec::with_capacity(rays.len());
        first.extend(rays.iter().enumerate().map(|(s, &r)| (s as u32, r)));
        RayList {
            lists: [first, Vec::with_capacity(rays.len())],
        }
    }

    /// Writes list `which` from the slots `remaining` (ascending) of `rays`.
    pub fn write(&mut self, which: u8, remaining: &[u32], ray_of: impl Fn(u32) -> u32) {
        let l = &mut self.lists[which as usize];
        l.clear();
        l.extend(remaining.iter().map(|&s| (s, ray_of(s))));
    }

    /// The (slot, ray) at `pos` of list `which`.
    #[inline]
    pub fn get(&self, which: u8, pos: u32) -> (u32, u32) {
        self.lists[which as usize][pos as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_join_writes_the_other_list_and_leaves_the_named_one() {
        let mut p = RayList::new(&[10, 11, 12]);
        assert_eq!(p.get(0, 2), (2, 12));
        let cap = p.lists[1].capacity();
        p.write(1, &[0, 2], |s| 10 + s);
        assert_eq!(p.lists[1], vec![(0, 10), (2, 12)]);
        assert_eq!(p.lists[0].len(), 3, "list 0 untouched");
        assert_eq!(p.lists[1].capacity(), cap, "no allocation");
    }
}
