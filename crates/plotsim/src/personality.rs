//! Which device the simulator is: the one choice every other setting
//! (quirks, paper, pen) depends on.

/// Which plotter the simulator pretends to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Personality {
    /// An HP 7475A (or, with another model name and buffer size, a 7550A,
    /// 7585B or a Roland DXY) speaking HP-GL over RS-232.
    Hp7475a,
    /// A GRBL 1.1 board speaking G-code with the character-counting protocol.
    Grbl,
    /// An EiBotBoard (AxiDraw, EggBot) on USB, firmware 2.8.1 or 3.0.2.
    Ebb,
}

impl Personality {
    /// The name used on the command line and in records.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Personality::Hp7475a => "hp7475a",
            Personality::Grbl => "grbl",
            Personality::Ebb => "ebb",
        }
    }

    /// Parses a command-line name (`hp7475a`, `grbl` or `ebb`).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "hp7475a" | "hpgl" | "hp" => Some(Personality::Hp7475a),
            "grbl" => Some(Personality::Grbl),
            "ebb" | "eibotboard" => Some(Personality::Ebb),
            _ => None,
        }
    }
}
