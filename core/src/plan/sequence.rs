//! The order of the projected frames and the one function that says what each frame shows.
//!
//! Order (fixed, so that a frame index alone identifies a pattern):
//! `[dark] [white]`, then for each group `g = 1, 2`: its fringes `m = 0..M`, then its masks.
//! Pattern generation, the simulator and the decoder all read frames through this module, so
//! they cannot disagree on what frame `i` is or on its intensity at column `c`.

use super::{Method, ScanPlan};

/// An EFSM pattern group (SPEC §3); BFSM uses [`Group::One`] only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Group {
    /// Group 1: no shift.
    One,
    /// Group 2: columns shifted by `cB/2`.
    Two,
}

impl Group {
    /// Both groups in sequence order.
    pub const ALL: [Group; 2] = [Group::One, Group::Two];

    /// 0 for group 1, 1 for group 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The SPEC's 1-based group number.
    pub fn number(self) -> u8 {
        self as u8 + 1
    }
}

/// What one frame of the sequence shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Pattern {
    /// Projector off.
    Dark,
    /// Every column full on.
    White,
    /// Fringe `index` (`m`, 0-based) of a group: `PA + PB·cos(2π f_m c̃)` (eqs. 4, 14).
    Fringe {
        /// The group.
        group: Group,
        /// `m`, 0-based.
        index: u16,
    },
    /// Mask `index` of a group: its block(s) full on, every other column off.
    Mask {
        /// The group.
        group: Group,
        /// Mask number, 0-based (equals the block number but for a shared edge mask).
        index: u16,
    },
}

impl ScanPlan {
    /// Frames before the first fringe: the reference frames.
    pub fn reference_count(&self) -> usize {
        self.references.dark as usize + self.references.white as usize
    }

    /// Fringe and mask patterns, without the reference frames (the paper's image count).
    pub fn pattern_count(&self) -> usize {
        self.groups().map(|g| self.group_len(g)).sum()
    }

    /// Every frame of the sequence, references included.
    pub fn sequence_len(&self) -> usize {
        self.reference_count() + self.pattern_count()
    }

    /// The groups of this plan in sequence order.
    pub fn groups(&self) -> impl Iterator<Item = Group> + Clone {
        Group::ALL.into_iter().take(self.group_count())
    }

    fn group_len(&self, group: Group) -> usize {
        self.band.count as usize + self.mask_count(group) as usize
    }

    /// Frame index of the dark reference.
    pub fn dark_index(&self) -> Option<usize> {
        self.references.dark.then_some(0)
    }

    /// Frame index of the white reference.
    pub fn white_index(&self) -> Option<usize> {
        self.references
            .white
            .then_some(self.references.dark as usize)
    }

    /// Frame index of fringe 0 of `group`.
    pub fn fringe_start(&self, group: Group) -> usize {
        let mut start = self.reference_count();
        for g in self.groups().take_while(|&g| g != group) {
            start += self.group_len(g);
        }
        start
    }

    /// Frame index of mask 0 of `group`.
    pub fn mask_start(&self, group: Group) -> usize {
        self.fringe_start(group) + self.band.count as usize
    }

    /// The pattern shown as frame `index`, or `None` past the end.
    pub fn pattern(&self, index: usize) -> Option<Pattern> {
        if Some(index) == self.dark_index() {
            return Some(Pattern::Dark);
        }
        if Some(index) == self.white_index() {
            return Some(Pattern::White);
        }
        let mut rest = index.checked_sub(self.reference_count())?;
        for group in self.groups() {
            let fringes = self.band.count as usize;
            if rest < fringes {
                return Some(Pattern::Fringe {
                    group,
                    index: rest as u16,
                });
            }
            rest -= fringes;
            let masks = self.mask_count(group) as usize;
            if rest < masks {
                return Some(Pattern::Mask {
                    group,
                    index: rest as u16,
                });
            }
            rest -= masks;
        }
        None
    }

    /// The frame index of `pattern`, or `None` if this plan does not show it.
    pub fn index_of(&self, pattern: Pattern) -> Option<usize> {
        match pattern {
            Pattern::Dark => self.dark_index(),
            Pattern::White => self.white_index(),
            Pattern::Fringe { group, index } => (index < self.band.count
                && group.index() < self.group_count())
            .then(|| self.fringe_start(group) + index as usize),
            Pattern::Mask { group, index } => (index < self.mask_count(group)
                && group.index() < self.group_count())
            .then(|| self.mask_start(group) + index as usize),
        }
    }

    /// Every frame of the sequence in order.
    pub fn sequence(&self) -> impl Iterator<Item = Pattern> + '_ {
        (0..self.sequence_len()).filter_map(|i| self.pattern(i))
    }

    /// Relative intensity in `[0, 1]` of `pattern` at projector column `column` (integer, since
    /// a projector column shows one value over its whole width, SPEC §7). Columns outside
    /// `0..cmax` are dark.
    pub fn intensity(&self, pattern: Pattern, column: u32) -> f32 {
        if column >= self.projector_columns as u32 {
            return 0.0;
        }
        match pattern {
            Pattern::Dark => 0.0,
            Pattern::White => 1.0,
            Pattern::Fringe { group, index } => {
                let (_, local) = self.block_of(column, group);
                let phase = self.fringe_phase_turns(index, local);
                let cos = libm::cos(core::f64::consts::TAU * phase);
                (self.levels.offset as f64 + self.levels.amplitude as f64 * cos) as f32
            }
            Pattern::Mask { group, index } => {
                let (block, _) = self.block_of(column, group);
                let lit = match self.method {
                    Method::Bfsm => false,
                    Method::Efsm(_) => self.mask_blocks(group, index).contains(block),
                };
                if lit {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// `f_m·c̃` reduced to one turn, `((n₁ + m)·c̃ mod L) / L`, exact in integers so that the
    /// cosine argument never loses precision at high columns.
    pub(crate) fn fringe_phase_turns(&self, m: u16, local_column: u32) -> f64 {
        let l = self.band.period_columns as u64;
        let harmonic = self.band.first_harmonic as u64 + m as u64;
        ((harmonic * local_column as u64) % l) as f64 / l as f64
    }
}
