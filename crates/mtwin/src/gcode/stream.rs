//! Streaming: a block reader over any [`BufRead`] (a 1 GB program is read
//! one line at a time), a block writer, and [`Program`] for programs small
//! enough to hold in memory.

use std::io::{BufRead, Write};

use super::error::GcodeError;
use super::syntax::Block;

/// Reads blocks one line at a time. Use [`BlockReader::read_block`] to reuse
/// one [`Block`]'s buffers (fastest), or iterate.
#[derive(Debug)]
pub struct BlockReader<R> {
    input: R,
    line: u64,
    bytes: u64,
}

impl<R: BufRead> BlockReader<R> {
    /// A reader starting at line 1.
    pub fn new(input: R) -> Self {
        BlockReader {
            input,
            line: 0,
            bytes: 0,
        }
    }

    /// Reads the next line into `block`; `Ok(false)` at the end of input.
    /// After a syntax error the reader stays usable: the next call reads the
    /// following line.
    pub fn read_block(&mut self, block: &mut Block) -> Result<bool, GcodeError> {
        let n = self.input.read_until(b'\n', block.text_buffer())?;
        if n == 0 {
            return Ok(false);
        }
        self.line += 1;
        self.bytes += n as u64;
        block.parse_own_text(self.line)?;
        Ok(true)
    }

    /// The input after the lines read so far (to copy what follows the end
    /// of a program unread).
    pub fn into_inner(self) -> R {
        self.input
    }

    /// Number of lines read so far.
    pub fn lines_read(&self) -> u64 {
        self.line
    }

    /// Number of bytes read so far.
    pub fn bytes_read(&self) -> u64 {
        self.bytes
    }
}

impl<R: BufRead> Iterator for BlockReader<R> {
    type Item = Result<Block, GcodeError>;

    fn next(&mut self) -> Option<Self::Item> {
        let mut block = Block::default();
        match self.read_block(&mut block) {
            Ok(true) => Some(Ok(block)),
            Ok(false) => None,
            Err(e) => Some(Err(e)),
        }
    }
}

/// Writes blocks one at a time, each with its own line end.
#[derive(Debug)]
pub struct BlockWriter<W> {
    out: W,
}

impl<W: Write> BlockWriter<W> {
    /// A writer into `out` (wrap files in a `BufWriter`).
    pub fn new(out: W) -> Self {
        BlockWriter { out }
    }

    /// Writes one block and its line end.
    pub fn write_block(&mut self, block: &Block) -> Result<(), GcodeError> {
        block.write_to(&mut self.out)?;
        Ok(())
    }

    /// Copies `input` as it is (the text after the end of a program).
    pub fn copy_raw<R: std::io::Read>(&mut self, mut input: R) -> Result<(), GcodeError> {
        std::io::copy(&mut input, &mut self.out)?;
        Ok(())
    }

    /// Flushes and returns the inner writer.
    pub fn into_inner(mut self) -> Result<W, GcodeError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// A whole program in memory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Program {
    /// The blocks, one per line; `blocks[i].line() == i + 1`.
    pub blocks: Vec<Block>,
}

impl Program {
    /// Parses a program held in memory.
    pub fn parse(bytes: &[u8]) -> Result<Program, GcodeError> {
        Program::read(bytes)
    }

    /// Parses a program held in memory up to its end as `opts` interpret
    /// it (M2, M30, the closing `%` of a program starting with `%`), as
    /// LinuxCNC reads it: the bytes after the end are not parsed. Returns
    /// the program and the length of the part read; `bytes[len..]` is the
    /// text after the end.
    pub fn parse_to_end(
        bytes: &[u8],
        opts: &super::InterpOptions,
    ) -> Result<(Program, usize), GcodeError> {
        let mut reader = BlockReader::new(bytes);
        let mut interp = super::Interpreter::new(opts.clone());
        let mut blocks = Vec::new();
        let mut block = Block::default();
        let mut events = Vec::new();
        while !interp.ended() && reader.read_block(&mut block)? {
            events.clear();
            interp.execute(&block, &mut events)?;
            blocks.push(block.clone());
        }
        let len = reader.bytes_read() as usize;
        Ok((Program { blocks }, len))
    }

    /// Reads a whole program from a reader.
    pub fn read<R: BufRead>(input: R) -> Result<Program, GcodeError> {
        let blocks = BlockReader::new(input).collect::<Result<Vec<_>, _>>()?;
        Ok(Program { blocks })
    }

    /// The program text: the concatenation of every block and its line end.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.blocks.iter().map(|b| b.text().len() + 2).sum());
        for b in &self.blocks {
            // Writing into a Vec cannot fail.
            let _ = b.write_to(&mut out);
        }
        out
    }
}
