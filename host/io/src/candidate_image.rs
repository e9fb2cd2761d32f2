//! The candidates of many pixels in memory, compactly: one flat list of candidates, an offset
//! per pixel, a flag byte per pixel. A scan holds its whole image this way instead of a
//! fixed-capacity [`PixelCandidates`] per pixel (16 candidates, 272 bytes, mostly empty):
//! a 1280x960 scan with two candidates per pixel takes about 45 MB instead of 334 MB.
//!
//! The decoding pipeline hands a scan its rows in this form ([`CandidateImage::of_row`]), and
//! a candidate file reads into it ([`CandidateImage::read_file`]), so both routes give the
//! same image, candidate for candidate.

use std::io::Read;

use fsm_core::{Candidate, PixelCandidates, PixelFlags};

use crate::candidate_file::{CandidateFileError, CandidateReader, HostCandidates};

/// The candidates of `height` camera rows from `first_row` on, `width` pixels each, row-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CandidateImage {
    width: usize,
    first_row: usize,
    height: usize,
    flags: Vec<PixelFlags>,
    /// `candidates[starts[i]..starts[i + 1]]` are pixel `i`'s.
    starts: Vec<u32>,
    candidates: Vec<Candidate>,
}

impl CandidateImage {
    /// No rows yet; the next pushed row is camera row `first_row`.
    pub fn new(width: usize, first_row: usize) -> Self {
        CandidateImage {
            width,
            first_row,
            height: 0,
            flags: Vec::new(),
            starts: vec![0],
            candidates: Vec::new(),
        }
    }

    /// Camera row `row` alone, from its pixels' candidate lists.
    pub fn of_row<const K: usize>(row: usize, pixels: &[PixelCandidates<K>]) -> Self {
        let mut image = CandidateImage::new(pixels.len(), row);
        image.push_row(pixels);
        image
    }

    /// Adds the next row, from its pixels' candidate lists (strongest first, as decoded).
    ///
    /// # Panics
    /// If `pixels` is not one row wide.
    pub fn push_row<const K: usize>(&mut self, pixels: &[PixelCandidates<K>]) {
        assert_eq!(
            pixels.len(),
            self.width,
            "one candidate list per pixel of the row"
        );
        for p in pixels {
            self.flags.push(p.flags);
            self.candidates.extend_from_slice(&p.candidates);
            self.starts.push(self.candidate_count_u32());
        }
        self.height += 1;
    }

    /// Adds the rows of `rows`, which must start where this image ends.
    ///
    /// # Panics
    /// If `rows` is not as wide or does not start at the next row.
    pub fn append(&mut self, rows: &CandidateImage) {
        assert_eq!(rows.width, self.width, "rows of the same width");
        assert_eq!(
            rows.first_row,
            self.first_row + self.height,
            "rows in order"
        );
        let base = self.candidate_count_u32();
        self.flags.extend_from_slice(&rows.flags);
        self.candidates.extend_from_slice(&rows.candidates);
        self.starts
            .extend(rows.starts[1..].iter().map(|&s| base + s));
        self.height += rows.height;
    }

    fn candidate_count_u32(&self) -> u32 {
        u32::try_from(self.candidates.len()).expect("fewer than 2^32 candidates in an image")
    }

    /// Reads a whole candidate file, row by row (one row's fixed-capacity lists at a time).
    /// The header's size is the image's; the caller checks its plan fingerprint.
    pub fn read_file<R: Read>(reader: &mut CandidateReader<R>) -> Result<Self, CandidateFileError> {
        let width = reader.header().width as usize;
        let mut image = CandidateImage::new(width, 0);
        let mut row = vec![HostCandidates::new(); width];
        while reader.next_row(&mut row)?.is_some() {
            image.push_row(&row);
        }
        Ok(image)
    }

    /// Pixels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Camera row of the first pixel.
    pub fn first_row(&self) -> usize {
        self.first_row
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixels (`width · height`).
    pub fn pixel_count(&self) -> usize {
        self.flags.len()
    }

    /// Candidates of all pixels.
    pub fn candidate_count(&self) -> usize {
        self.candidates.len()
    }

    /// Pixel `i`'s flags (row-major index from the first row).
    pub fn flags(&self, i: usize) -> PixelFlags {
        self.flags[i]
    }

    /// Pixel `i`'s candidates, strongest first.
    pub fn candidates(&self, i: usize) -> &[Candidate] {
        &self.candidates[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// Every pixel's flags and candidates, row-major.
    pub fn pixels(&self) -> impl ExactSizeIterator<Item = (PixelFlags, &[Candidate])> + '_ {
        (0..self.pixel_count()).map(|i| (self.flags[i], self.candidates(i)))
    }

    /// Pixels flagged with `flag`.
    pub fn count_flagged(&self, flag: PixelFlags) -> usize {
        self.flags.iter().filter(|f| f.contains(flag)).count()
    }

    /// Camera rows whose every pixel is flagged [`PixelFlags::NO_DATA`] (rows the capture held
    /// no valid samples of), in order.
    pub fn rows_without_data(&self) -> Vec<u32> {
        if self.width == 0 {
            return Vec::new();
        }
        self.flags
            .chunks(self.width)
            .enumerate()
            .filter(|(_, row)| row.iter().all(|f| f.contains(PixelFlags::NO_DATA)))
            .map(|(y, _)| (self.first_row + y) as u32)
            .collect()
    }

    /// Bytes the image holds on the heap (its lists' lengths, not their spare capacity).
    pub fn heap_bytes(&self) -> usize {
        self.flags.len() * std::mem::size_of::<PixelFlags>()
            + self.starts.len() * std::mem::size_of::<u32>()
            + self.candidates.len() * std::mem::size_of::<Candidate>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::{Group, GroupSet};

    fn candidate(column: f32, amplitude: f32) -> Candidate {
        Candidate {
            column,
            amplitude,
            groups: GroupSet::only(Group::One),
            group: Group::One,
            peak: 0,
            block: 0,
        }
    }

    fn pixel(columns: &[f32], flags: PixelFlags) -> HostCandidates {
        let mut p = HostCandidates::new();
        for (k, &c) in columns.iter().enumerate() {
            p.candidates
                .push(candidate(c, 100.0 - k as f32))
                .expect("capacity");
        }
        p.flags = flags;
        p
    }

    #[test]
    fn rows_pushed_or_appended_read_back_pixel_by_pixel() {
        let rows = [
            vec![
                pixel(&[3.0, 40.5], PixelFlags::default()),
                pixel(&[], PixelFlags::NO_DATA),
                pixel(&[7.25], PixelFlags::ALIASED),
            ],
            vec![
                pixel(&[], PixelFlags::default()),
                pixel(&[1.0, 2.0, 3.0], PixelFlags::SATURATED),
                pixel(&[9.0], PixelFlags::default()),
            ],
        ];
        let mut pushed = CandidateImage::new(3, 5);
        for row in &rows {
            pushed.push_row(row);
        }
        let mut appended = CandidateImage::of_row(5, &rows[0]);
        appended.append(&CandidateImage::of_row(6, &rows[1]));
        assert_eq!(pushed, appended);
        assert_eq!((pushed.first_row(), pushed.height()), (5, 2));
        assert_eq!((pushed.pixel_count(), pushed.candidate_count()), (6, 7));
        for (i, (flags, candidates)) in pushed.pixels().enumerate() {
            let p = &rows[i / 3][i % 3];
            assert_eq!(flags, p.flags, "pixel {i}");
            assert_eq!(candidates, &p.candidates[..], "pixel {i}");
        }
        assert_eq!(pushed.count_flagged(PixelFlags::NO_DATA), 1);
        assert!(pushed.rows_without_data().is_empty());
        let mut gap = pushed.clone();
        gap.push_row(&[
            pixel(&[], PixelFlags::NO_DATA),
            pixel(&[], PixelFlags::NO_DATA),
            pixel(&[], PixelFlags::NO_DATA),
        ]);
        assert_eq!(gap.rows_without_data(), [7]);
        assert_eq!(pushed.heap_bytes(), 6 + 7 * 4 + 7 * 16);
    }

    #[test]
    #[should_panic(expected = "rows in order")]
    fn rows_out_of_order_are_refused() {
        let row = [pixel(&[1.0], PixelFlags::default())];
        let mut image = CandidateImage::of_row(0, &row);
        image.append(&CandidateImage::of_row(2, &row));
    }
}
