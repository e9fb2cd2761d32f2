//! Candidates: the projector columns that may light a pixel, direct or indirect (paper eq. 18).
//!
//! Each pixel gets a fixed-capacity list, strongest first. The direct column is among them; the
//! selection of SPEC §4 (host side) picks it.

use heapless::Vec;

use crate::plan::sequence::Group;

/// One candidate projector column of a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Candidate {
    /// Projector column (SPEC §1: column `j` has its centre at `c = j`).
    pub column: f32,
    /// Fringe modulation of the peak that produced it, sensor DN (`I_c` of eq. 10).
    pub amplitude: f32,
    /// The groups whose peaks produced this column (both, when the two groups agree).
    pub groups: GroupSet,
    /// The group whose peak and block are reported (the first of two groups whose views of the
    /// column were averaged).
    pub group: Group,
    /// Rank of the producing peak in its group's spectrum (0 = strongest).
    pub peak: u8,
    /// EFSM block combined with the peak (eqs. 19–20); 0 for BFSM.
    pub block: u16,
}

/// A set of pattern groups.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GroupSet(pub u8);

impl GroupSet {
    /// The set holding only `group`.
    pub fn only(group: Group) -> Self {
        GroupSet(1 << group.index())
    }

    /// Whether `group` is in the set.
    pub fn contains(self, group: Group) -> bool {
        self.0 & (1 << group.index()) != 0
    }

    /// Whether the sets share a group.
    pub fn intersects(self, other: GroupSet) -> bool {
        self.0 & other.0 != 0
    }

    /// Union.
    pub fn union(self, other: GroupSet) -> Self {
        GroupSet(self.0 | other.0)
    }
}

/// Per-pixel conditions the decoder noticed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PixelFlags(pub u8);

impl PixelFlags {
    /// A sample the decoder used reached the sensor's saturation code: clipped fringes carry
    /// harmonics, so candidates may include ghosts.
    pub const SATURATED: PixelFlags = PixelFlags(1);
    /// More candidates than the list holds: the weakest were dropped.
    pub const TRUNCATED: PixelFlags = PixelFlags(2);
    /// EFSM: in every group, lights of two blocks fall within `2Δc` of each other in the local
    /// column domain (paper §IV-C): a peak holds more light than any one block sends, or two
    /// peaks are closer than `2Δc`. Such peaks are mixtures, off by up to a column, so a scan
    /// should not trust this pixel's candidates.
    pub const ALIASED: PixelFlags = PixelFlags(4);
    /// BFSM, cosine search: two lights of the pixel touch with a dip between them well above
    /// the noise but too shallow to tell their footprints apart; the candidate for them is
    /// their mixture, off by up to half their distance, so a scan should not trust it.
    pub const UNRESOLVED: PixelFlags = PixelFlags(8);
    /// The capture held no valid samples of this pixel: its row was corrupt or missing and
    /// was skipped on request (a host's `--skip-bad-rows`). No light was looked for, so the
    /// pixel's empty list says nothing about the scene. The decoder never sets it.
    pub const NO_DATA: PixelFlags = PixelFlags(16);

    /// Whether the pixel's candidates may be mixtures of two lights ([`PixelFlags::ALIASED`] or
    /// [`PixelFlags::UNRESOLVED`]): a scan gives such a pixel no point unless asked to.
    pub fn is_mixed(self) -> bool {
        self.0 & (PixelFlags::ALIASED.0 | PixelFlags::UNRESOLVED.0) != 0
    }

    /// Whether every flag of `other` is set.
    pub fn contains(self, other: PixelFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// Sets the flags of `other`.
    pub fn insert(&mut self, other: PixelFlags) {
        self.0 |= other.0;
    }
}

/// The candidates of one pixel, strongest first, at most `K`.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PixelCandidates<const K: usize> {
    /// Candidates by decreasing amplitude (equal amplitudes by increasing column).
    pub candidates: Vec<Candidate, K>,
    /// Conditions noticed while decoding.
    pub flags: PixelFlags,
    /// Sample noise RMS estimated from the pixel's residual spectrum, sensor DN (largest of
    /// the groups).
    pub noise_dn: f32,
}

impl<const K: usize> PixelCandidates<K> {
    /// An empty list.
    pub const fn new() -> Self {
        PixelCandidates {
            candidates: Vec::new(),
            flags: PixelFlags(0),
            noise_dn: 0.0,
        }
    }

    /// Empties the list for reuse.
    pub fn clear(&mut self) {
        self.candidates.clear();
        self.flags = PixelFlags::default();
        self.noise_dn = 0.0;
    }

    /// The strongest candidate.
    pub fn strongest(&self) -> Option<&Candidate> {
        self.candidates.first()
    }

    /// Adds a candidate. A candidate of another group within `merge_tolerance` columns of an
    /// existing one is the same column seen twice: one entry remains, what `merge(existing,
    /// new)` makes of the two (EFSM: their average where both groups see the column well inside
    /// a block, else the view further from a block border), with the union of the groups. When
    /// the list is full the weakest candidate gives way and the pixel is flagged
    /// [`PixelFlags::TRUNCATED`].
    pub(crate) fn offer(
        &mut self,
        candidate: Candidate,
        merge_tolerance: f32,
        merge: impl Fn(&Candidate, &Candidate) -> Candidate,
    ) {
        for c in self.candidates.iter_mut() {
            if !c.groups.intersects(candidate.groups)
                && (c.column - candidate.column).abs() <= merge_tolerance
            {
                let groups = c.groups.union(candidate.groups);
                *c = merge(c, &candidate);
                c.groups = groups;
                return;
            }
        }
        if self.candidates.push(candidate).is_ok() {
            return;
        }
        self.flags.insert(PixelFlags::TRUNCATED);
        let weakest = self
            .candidates
            .iter()
            .enumerate()
            .max_by(|a, b| rank(a.1, b.1))
            .map(|(i, c)| (i, *c));
        if let Some((i, w)) = weakest {
            if rank(&candidate, &w).is_lt() {
                self.candidates[i] = candidate;
            }
        }
    }

    /// Orders the list strongest first (insertion sort: `K` is small and the order must not
    /// depend on the sort algorithm).
    pub(crate) fn sort(&mut self) {
        let c = &mut self.candidates;
        for i in 1..c.len() {
            let mut j = i;
            while j > 0 && rank(&c[j], &c[j - 1]).is_lt() {
                c.swap(j, j - 1);
                j -= 1;
            }
        }
    }
}

/// Total order "stronger first": amplitude descending, then column ascending.
fn rank(a: &Candidate, b: &Candidate) -> core::cmp::Ordering {
    b.amplitude
        .total_cmp(&a.amplitude)
        .then(a.column.total_cmp(&b.column))
}

/// The columns a pixel's candidates may take (inclusive); the host narrows it per pixel with
/// depth limits.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ColumnRange {
    /// Smallest column kept.
    pub first: f32,
    /// Largest column kept.
    pub last: f32,
}

impl ColumnRange {
    /// Every column a projector of `columns` columns has: `[−0.5, cmax − 0.5]`.
    pub fn projector(columns: u16) -> Self {
        ColumnRange {
            first: -0.5,
            last: columns as f32 - 0.5,
        }
    }

    /// Whether `column` lies in the range.
    pub fn contains(&self, column: f32) -> bool {
        column >= self.first && column <= self.last
    }

    /// The overlap of two ranges (empty if `first > last`).
    pub fn intersect(&self, other: &ColumnRange) -> ColumnRange {
        ColumnRange {
            first: self.first.max(other.first),
            last: self.last.min(other.last),
        }
    }
}
