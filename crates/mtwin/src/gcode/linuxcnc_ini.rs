//! A LinuxCNC INI file as LinuxCNC's `IniFile::Find` reads it: `[SECTION]`
//! headers and `NAME = VALUE` entries, lines starting with `#` or `;` are
//! comments; a name is looked up in the **first** section of its name only
//! (a repeated section is not searched), and there its **first** entry
//! counts. Names are compared as written (LinuxCNC's are upper case).
//!
//! The one reader of INI text for the interpreter: `#<_ini[…]>` parameters
//! ([`super::parameters::Parameters::load_ini`]), the subroutine path and
//! Python top level ([`super::program_flow::ProgramOptions::apply_ini`]) and
//! the axes of `[TRAJ] COORDINATES` ([`super::AxisMask::of_linuxcnc_ini`]).

/// The entries of an INI text that LinuxCNC's lookup can reach.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LinuxcncIni<'a> {
    /// Section names in file order, each once (its first occurrence).
    sections: Vec<&'a str>,
    /// `(section, name, value)` of the reachable entries, in file order:
    /// in each section's first occurrence, the first entry of each name.
    entries: Vec<(&'a str, &'a str, &'a str)>,
}

impl<'a> LinuxcncIni<'a> {
    /// Reads INI text (never fails: a line that is neither a header, an
    /// entry nor a comment is left out, as LinuxCNC does).
    pub fn parse(text: &'a str) -> LinuxcncIni<'a> {
        let mut ini = LinuxcncIni::default();
        // The section being read, `None` before the first header and in a
        // repeated section.
        let mut section: Option<&'a str> = None;
        for line in text.lines() {
            let t = line.trim();
            if let Some(rest) = t.strip_prefix('[') {
                let name = rest.split(']').next().unwrap_or("").trim();
                section = if ini.sections.contains(&name) {
                    None
                } else {
                    ini.sections.push(name);
                    Some(name)
                };
                continue;
            }
            if t.starts_with(['#', ';']) {
                continue;
            }
            let (Some(sec), Some((key, value))) = (section, t.split_once('=')) else {
                continue;
            };
            let key = key.trim();
            if !ini.entries.iter().any(|&(s, k, _)| s == sec && k == key) {
                ini.entries.push((sec, key, value.trim()));
            }
        }
        ini
    }

    /// The value of `name` in `section` (trimmed), as LinuxCNC finds it.
    pub fn get(&self, section: &str, name: &str) -> Option<&'a str> {
        self.entries
            .iter()
            .find(|&&(s, k, _)| s == section && k == name)
            .map(|&(_, _, v)| v)
    }

    /// True when the file has a `[section]` header.
    pub fn has_section(&self, section: &str) -> bool {
        self.sections.contains(&section)
    }

    /// Every reachable `(section, name, value)`, in file order.
    pub fn entries(&self) -> impl Iterator<Item = (&'a str, &'a str, &'a str)> + '_ {
        self.entries.iter().copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_section_and_the_first_entry_of_a_name_count() {
        let ini = LinuxcncIni::parse(
            "top = 1\n[A]\nX = 1\n# X = 9\n; Y = 9\nX = 2\n Y = two words \n[B]\nX = 3\n[A]\nX = 4\nZ = 5\nnot an entry\n",
        );
        assert_eq!(ini.get("A", "X"), Some("1"));
        assert_eq!(ini.get("A", "Y"), Some("two words"));
        assert_eq!(ini.get("B", "X"), Some("3"));
        // The repeated [A] is not searched; nothing before the first header.
        assert_eq!(ini.get("A", "Z"), None);
        assert_eq!(ini.get("", "top"), None);
        assert!(ini.has_section("B") && !ini.has_section("C"));
        let all: Vec<_> = ini.entries().collect();
        assert_eq!(
            all,
            [("A", "X", "1"), ("A", "Y", "two words"), ("B", "X", "3")]
        );
    }
}
