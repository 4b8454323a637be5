//! Partitions: maximal runs of sorted draws that share a pass class and variant.

use crate::{DrawIndexedIndirect, DrawMetadata, PassMask};

/// A contiguous range `[begin, end)` of a view's sorted draws with one mask,
/// and the draw commands that draw them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Partition {
    /// First draw.
    pub begin: u32,
    /// One past the last draw.
    pub end: u32,
    /// The pass class and variant bits ([`PassMask::PARTITION_BITS`]).
    pub mask: PassMask,
    /// First of the partition's draw commands in the view's indirect
    /// arguments ([`crate::PreparedSceneFrame::indirect_args`]).
    pub first_command: u32,
    /// Its draw commands: one per draw, or fewer when runs of draws sharing
    /// a mesh are instanced ([`crate::Instancing`]). For a partition the GPU
    /// writes, the most there can be.
    pub command_count: u32,
    /// `None` when the CPU wrote the partition (its draws are in
    /// [`crate::PreparedSceneFrame::draws`]). `Some(counter)` when a GPU
    /// visibility path writes its draws and commands
    /// ([`crate::Visibility`]): the commands actually written are counted in
    /// that counter of the view's count buffer, the draws are not on the CPU,
    /// and `begin..end` is the room they may take.
    pub gpu_count: Option<u32>,
}

impl Partition {
    /// Number of draws.
    pub fn len(&self) -> u32 {
        self.end - self.begin
    }

    /// True for an empty range (never produced by finalization).
    pub fn is_empty(&self) -> bool {
        self.begin == self.end
    }

    /// The draw index range.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.begin as usize..self.end as usize
    }

    /// The command index range.
    pub fn commands(&self) -> std::ops::Range<usize> {
        self.first_command as usize..(self.first_command + self.command_count) as usize
    }
}

/// Splits sorted draws into partitions (cleared first).
pub fn build_partitions(draws: &[DrawMetadata], out: &mut Vec<Partition>) {
    out.clear();
    for (i, draw) in draws.iter().enumerate() {
        let mask = draw.mask() & PassMask::PARTITION_BITS;
        match out.last_mut() {
            Some(last) if last.mask == mask => last.end = i as u32 + 1,
            _ => out.push(Partition {
                begin: i as u32,
                end: i as u32 + 1,
                mask,
                first_command: 0,
                command_count: 0,
                gpu_count: None,
            }),
        }
    }
}

/// Writes the draw commands of `partitions` into `commands` (cleared first):
/// one per draw, or with `merge` one per run of consecutive draws of a
/// partition that share their geometry, with `instance_count` the run's
/// length and `first_instance` its first draw (each instance finds its own
/// draw at `first_instance + instance_index`).
pub fn build_commands(
    draws: &[DrawMetadata],
    partitions: &mut [Partition],
    merge: bool,
    commands: &mut Vec<DrawIndexedIndirect>,
) {
    commands.clear();
    for partition in partitions.iter_mut() {
        partition.first_command = commands.len() as u32;
        for index in partition.begin..partition.end {
            let command = DrawIndexedIndirect::for_draw(&draws[index as usize], index);
            // Only a command of this partition may be extended.
            let open = commands.len() as u32 > partition.first_command;
            match commands.last_mut() {
                Some(last)
                    if merge
                        && open
                        && last.first_instance + last.instance_count == index
                        && (last.index_count, last.first_index, last.base_vertex)
                            == (command.index_count, command.first_index, command.base_vertex) =>
                {
                    last.instance_count += command.instance_count;
                }
                _ => commands.push(command),
            }
        }
        partition.command_count = commands.len() as u32 - partition.first_command;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A draw of one 36-index mesh at `vertex_slot` with `mask`.
    fn draw(mask: PassMask, vertex_slot: u32) -> DrawMetadata {
        DrawMetadata {
            vertex_slot,
            index_slot: 0,
            first_index: 0,
            index_count: 36,
            instance_count: 1,
            pass_mask: mask.bits(),
            ..Default::default()
        }
    }

    /// A partition's `len` is the number of draws it spans (also for one
    /// that does not start at draw 0) and `is_empty` tells the empty range
    /// apart: what a pass reads to size and skip its draws.
    #[test]
    fn a_partition_knows_how_many_draws_it_spans() {
        let opaque = PassMask::OPAQUE;
        let masked = PassMask::MASKED;
        let draws = [draw(opaque, 0), draw(opaque, 0), draw(masked, 0), draw(masked, 0), draw(masked, 0)];
        let mut partitions = Vec::new();
        build_partitions(&draws, &mut partitions);
        let spans: Vec<_> = partitions.iter().map(|p| (p.range(), p.len(), p.is_empty())).collect();
        assert_eq!(spans, vec![(0..2, 2, false), (2..5, 3, false)]);
        let empty = Partition { begin: 5, end: 5, ..partitions[1] };
        assert_eq!((empty.len(), empty.is_empty()), (0, true));
    }

    /// Instancing merges runs of one mesh within a partition only: when the
    /// last draw of a partition and the first of the next share their
    /// geometry, the next partition still starts a command of its own, since
    /// it is drawn with another pipeline (here double-sided).
    #[test]
    fn merged_commands_never_cross_a_partition_boundary() {
        let single = PassMask::OPAQUE;
        let double = PassMask::OPAQUE | PassMask::DOUBLE_SIDED;
        let draws = [draw(single, 0), draw(single, 0), draw(double, 0), draw(double, 0)];
        let mut partitions = Vec::new();
        build_partitions(&draws, &mut partitions);
        let mut commands = Vec::new();
        build_commands(&draws, &mut partitions, true, &mut commands);
        let runs: Vec<_> = commands.iter().map(|c| (c.first_instance, c.instance_count)).collect();
        assert_eq!(runs, vec![(0, 2), (2, 2)], "one instanced command per partition");
        assert_eq!(partitions.iter().map(Partition::commands).collect::<Vec<_>>(), vec![0..1, 1..2]);
    }
}
