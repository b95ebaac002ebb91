//! The one door through which the holodeck file's bytes go to the disk: [`Disk`] wraps the
//! open [`File`], and every write and every `fsync` of a [`HoloFile`](super::HoloFile) goes
//! through it. Reads go straight to the file (they see every write, synced or not, as the
//! page cache does).
//!
//! Under test a [`Disk`] can also keep a power-cut journal ([`PowerCut`]): the bytes that
//! have been synced, and the writes made since. A power cut keeps only the synced bytes
//! and any subset of the unsynced writes (a disk may reorder them), which a SIGKILL cannot
//! show: the killed process's writes stay in the page cache.

use std::fs::File;
use std::os::unix::fs::FileExt;

/// The file under a [`HoloFile`](super::HoloFile).
pub struct Disk {
    file: File,
    #[cfg(test)]
    journal: Option<std::sync::Arc<std::sync::Mutex<PowerCut>>>,
}

impl Disk {
    pub fn new(file: File) -> Self {
        Self {
            file,
            #[cfg(test)]
            journal: None,
        }
    }

    /// The file, for reading.
    pub fn file(&self) -> &File {
        &self.file
    }

    /// Writes `bytes` at `offset` (not durable until [`Disk::sync_data`]).
    pub fn write_all_at(&self, bytes: &[u8], offset: u64) -> std::io::Result<()> {
        self.file.write_all_at(bytes, offset)?;
        #[cfg(test)]
        if let Some(j) = &self.journal {
            j.lock().expect("journal").write(bytes, offset);
        }
        Ok(())
    }

    /// Makes every write so far durable.
    pub fn sync_data(&self) -> std::io::Result<()> {
        self.file.sync_data()?;
        #[cfg(test)]
        if let Some(j) = &self.journal {
            j.lock().expect("journal").sync();
        }
        Ok(())
    }

    /// Starts a power-cut journal; the file's bytes now count as durable.
    #[cfg(test)]
    pub(crate) fn journal(&mut self) -> std::sync::Arc<std::sync::Mutex<PowerCut>> {
        let len = self.file.metadata().expect("the file's length").len();
        let mut durable = vec![0; len as usize];
        self.file
            .read_exact_at(&mut durable, 0)
            .expect("read the file");
        let j = std::sync::Arc::new(std::sync::Mutex::new(PowerCut {
            durable,
            unsynced: Vec::new(),
            ops: 0,
            cut_every: None,
            cuts: Vec::new(),
            rng: 1,
        }));
        self.journal = Some(j.clone());
        j
    }
}

/// The test double of a disk that loses power: what is durable, what is not yet, and the
/// images a power cut would leave.
#[cfg(test)]
pub(crate) struct PowerCut {
    /// The bytes as of the last sync.
    durable: Vec<u8>,
    /// Writes since the last sync, in order.
    unsynced: Vec<(u64, Vec<u8>)>,
    /// Writes and syncs so far.
    ops: u64,
    /// Cut the power after every this many operations (see [`PowerCut::take_cuts`]).
    cut_every: Option<u64>,
    cuts: Vec<Vec<u8>>,
    /// xorshift state choosing which unsynced writes survive a cut.
    rng: u64,
}

#[cfg(test)]
impl PowerCut {
    fn write(&mut self, bytes: &[u8], offset: u64) {
        self.unsynced.push((offset, bytes.to_vec()));
        self.op();
    }

    fn sync(&mut self) {
        for (offset, bytes) in std::mem::take(&mut self.unsynced) {
            apply(&mut self.durable, offset, &bytes);
        }
        self.op();
    }

    fn op(&mut self) {
        self.ops += 1;
        if self.cut_every.is_some_and(|n| self.ops.is_multiple_of(n)) {
            let image = self.image();
            self.cuts.push(image);
        }
    }

    /// What a power cut now leaves: the synced bytes and a random subset of the writes
    /// made since (each kept or lost, as a disk's cache may write them in any order).
    pub(crate) fn image(&mut self) -> Vec<u8> {
        let mut out = self.durable.clone();
        for (offset, bytes) in &self.unsynced {
            self.rng ^= self.rng << 13;
            self.rng ^= self.rng >> 7;
            self.rng ^= self.rng << 17;
            if self.rng & 1 == 1 {
                apply(&mut out, *offset, bytes);
            }
        }
        out
    }

    /// Takes a power-cut image after every `n` operations from now on (`seed` chooses
    /// which unsynced writes each keeps).
    pub(crate) fn cut_every(&mut self, n: u64, seed: u64) {
        self.cut_every = Some(n);
        self.rng = seed | 1;
    }

    /// The images taken since the last call.
    pub(crate) fn take_cuts(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.cuts)
    }
}

#[cfg(test)]
fn apply(image: &mut Vec<u8>, offset: u64, bytes: &[u8]) {
    let (start, end) = (offset as usize, offset as usize + bytes.len());
    if image.len() < end {
        image.resize(end, 0);
    }
    image[start..end].copy_from_slice(bytes);
}
