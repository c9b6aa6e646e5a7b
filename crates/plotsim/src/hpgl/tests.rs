//! The HP personality driven directly, with a hand-moved clock.

use super::*;
use crate::record::Record;

struct Rig {
    hp: Hp,
    record: Record,
    out: Vec<u8>,
    now: Instant,
    garble: bool,
    scale: f64,
}

impl Rig {
    fn new(cfg: SimConfig) -> Rig {
        let now = Instant::now();
        Rig { hp: Hp::new(&cfg, now), record: Record::default(), out: Vec::new(), now, garble: false, scale: cfg.speed_scale }
    }

    fn instant() -> Rig {
        Rig::new(SimConfig::hp7475a().with_speed_scale(0.0))
    }

    fn with<R>(&mut self, f: impl FnOnce(&mut Hp, &mut Ctx<'_>) -> R) -> R {
        let mut ctx =
            Ctx { now: self.now, out: &mut self.out, record: &mut self.record, speed_scale: self.scale, garble_next: &mut self.garble };
        f(&mut self.hp, &mut ctx)
    }

    /// Bytes arrive (no execution).
    fn arrive(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.record.bytes_received += 1;
            self.with(|hp, ctx| hp.receive(b, ctx));
        }
    }

    fn run(&mut self) -> Option<Instant> {
        self.with(|hp, ctx| hp.run(ctx))
    }

    /// Bytes arrive and the device runs; returns what it said.
    fn send(&mut self, bytes: &[u8]) -> String {
        self.arrive(bytes);
        self.run();
        self.take()
    }

    fn take(&mut self) -> String {
        String::from_utf8_lossy(&std::mem::take(&mut self.out)).into_owned()
    }
}

#[test]
fn output_instructions_answer_with_cr() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"OI;"), "7475A\r");
    assert_eq!(r.send(b"OS;"), "24\r", "initialized + ready after power-on");
    assert_eq!(r.send(b"OS;"), "16\r", "reading OS clears the initialized bit");
    assert_eq!(r.send(b"OH;"), "0,0,11040,7721\r");
    assert_eq!(r.send(b"OF;"), "40,40\r");
    assert_eq!(r.send(b"OP;"), "603,521,10603,7721\r");
    assert_eq!(r.send(b"SP1;PD;PA100,200;OA;"), "100,200,1\r");
    assert_eq!(r.send(b"PU;OA;"), "100,200,0\r");
}

#[test]
fn pen_down_moves_are_recorded_per_pen_and_pen_up_moves_are_not() {
    let mut r = Rig::instant();
    r.send(b"IN;SP1;PU0,0;PD400,0,400,400;PU;PA1000,1000;SP2;PD1000,2000;PR10,0;PU;");
    let s = &r.record.strokes;
    assert_eq!(s.len(), 2);
    assert_eq!(s[0].pen, 1);
    assert_eq!(s[0].points, vec![[0.0, 0.0], [400.0, 0.0], [400.0, 400.0]]);
    assert_eq!(s[1].pen, 2);
    assert_eq!(s[1].points, vec![[1000.0, 1000.0], [1000.0, 2000.0], [1010.0, 2000.0]]);
    // Pen-up moves are travel: where each ended, the pen drawing nothing.
    assert_eq!(r.record.travel, vec![[0.0, 0.0], [1000.0, 1000.0]]);
}

#[test]
fn no_pen_draws_nothing_and_lines_are_clipped_at_the_hard_limits() {
    let mut r = Rig::instant();
    r.send(b"PD100,100;PU;");
    assert!(r.record.strokes.is_empty(), "SP0: no pen in the holder");
    r.send(b"SP1;PA-100,0;PD100,0;PU;");
    assert_eq!(r.record.strokes[0].points, vec![[0.0, 0.0], [100.0, 0.0]]);
}

#[test]
fn errors_set_oe_and_the_os_error_bit() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"ZZ;OS;"), "56\r", "8 initialized + 16 ready + 32 error");
    assert_eq!(r.send(b"OE;"), "1\r");
    assert_eq!(r.send(b"OE;"), "0\r", "reading OE clears it");
    assert_eq!(r.send(b"PA10;OE;"), "2\r", "odd coordinate count");
    assert_eq!(r.send(b"SP9;OE;"), "3\r", "six pens");
    assert_eq!(r.send(b"PA40000,0;OE;"), "3\r");
    assert_eq!(r.send(b"VS200;OE;"), "3\r");
    assert_eq!(r.send(b"IN;OE;"), "0\r");
    let codes: Vec<u32> = r.record.errors.iter().map(|e| e.code).collect();
    assert_eq!(codes, vec![1, 2, 3, 3, 3]);
}

#[test]
fn device_control_answers_on_arrival_even_while_paused() {
    let mut r = Rig::instant();
    r.hp.set_lever(true).unwrap();
    r.arrive(b"SP1;PD100,100;");
    assert_eq!(r.take(), "");
    r.arrive(b"\x1b.B");
    assert_eq!(r.take(), format!("{}\r", 1024 - 14));
    r.arrive(b"\x1b.O");
    assert_eq!(r.take(), "32\r", "lever up, buffer not empty");
    r.arrive(b"\x1b.L");
    assert_eq!(r.take(), "1024\r");
    r.run();
    assert!(r.record.strokes.is_empty(), "nothing plots with the lever up");
    r.hp.set_lever(false).unwrap();
    r.run();
    r.arrive(b"\x1b.O");
    assert_eq!(r.take(), "8\r");
    assert_eq!(r.record.strokes.len(), 1);
}

#[test]
fn overflow_loses_bytes_counts_them_and_reports_error_16_once() {
    let mut r = Rig::new(SimConfig::hp7475a().with_buffer_size(32).with_speed_scale(0.0));
    r.hp.set_lever(true).unwrap();
    r.arrive(&[b' '; 40]);
    assert_eq!(r.record.overruns, 8);
    assert_eq!(r.record.errors.len(), 1);
    r.arrive(b"\x1b.B\x1b.E");
    assert_eq!(r.take(), "0\r16\r");
    r.arrive(b"\x1b.E");
    assert_eq!(r.take(), "0\r", "ESC.E clears the extended error");
}

#[test]
fn abort_discards_the_buffer() {
    let mut r = Rig::instant();
    r.hp.set_lever(true).unwrap();
    r.arrive(b"SP1;PD0,0,100,100;");
    r.arrive(b"\x1b.K\x1b.B");
    assert_eq!(r.take(), "1024\r");
    r.hp.set_lever(false).unwrap();
    r.run();
    assert!(r.record.strokes.is_empty());
}

#[test]
fn bad_device_control_sets_extended_errors() {
    let mut r = Rig::instant();
    for (seq, code) in [(&b"\x1b.Q"[..], "11"), (b"\x1b.@1x", "12"), (b"\x1b.@5000:", "13"), (b"\x1b.@1;2;3:", "14")] {
        r.arrive(seq);
        r.arrive(b"\x1b.E");
        assert_eq!(r.take(), format!("{code}\r"), "{:?}", String::from_utf8_lossy(seq));
    }
}

#[test]
fn xon_xoff_thresholds_follow_esc_i_and_esc_n() {
    let mut r = Rig::instant();
    r.hp.set_lever(true).unwrap();
    // XOFF threshold 100 free bytes, XON = DC1, XOFF = DC3.
    r.arrive(b"\x1b.I100;;17:\x1b.N;19:");
    r.arrive(&[b' '; 924]);
    assert_eq!(r.take(), "", "100 bytes still free");
    r.arrive(b" ");
    assert_eq!(r.take(), "\x13", "fewer than 100 free: XOFF");
    r.arrive(b" ");
    assert_eq!(r.take(), "", "XOFF is sent once");
    assert!(r.hp.status().xoff);
    r.hp.set_lever(false).unwrap();
    r.run();
    assert_eq!(r.take(), "\x11", "drained to 128 stored or fewer: XON");
    assert_eq!(r.record.overruns, 0);
}

#[test]
fn enquire_acknowledge_waits_for_a_block_of_space() {
    let mut r = Rig::new(SimConfig::hp7475a().with_buffer_size(100).with_speed_scale(0.0));
    r.hp.set_lever(true).unwrap();
    // Block 50, ENQ = 5, ACK = 6.
    r.arrive(b"\x1b.H50;5;6:");
    r.arrive(&[5]);
    assert_eq!(r.take(), "\x06");
    r.arrive(&[b' '; 60]);
    r.arrive(&[5]);
    assert_eq!(r.take(), "", "40 free < block of 50: answer withheld");
    r.hp.set_lever(false).unwrap();
    r.run();
    assert_eq!(r.take(), "\x06");
}

#[test]
fn hardwire_handshake_drops_cts_under_the_block_size() {
    let mut r = Rig::new(SimConfig::hp7475a().with_buffer_size(100).with_speed_scale(0.0));
    r.hp.set_lever(true).unwrap();
    assert!(r.hp.status().cts);
    r.arrive(b"\x1b.@;1:\x1b.I30:");
    r.arrive(&[b' '; 70]);
    assert!(r.hp.status().cts);
    r.arrive(b" ");
    assert!(!r.hp.status().cts);
}

#[test]
fn esc_m_changes_the_terminator_and_esc_at_the_logical_buffer() {
    let mut r = Rig::instant();
    r.arrive(b"\x1b.M;;;13;10:\x1b.@512:\x1b.L");
    assert_eq!(r.take(), "512\r\n");
    r.arrive(b"\x1b.R\x1b.M:\x1b.B");
    assert_eq!(r.take(), "512\r");
}

#[test]
fn garbage_replaces_one_reply() {
    let mut r = Rig::instant();
    r.garble = true;
    let a = r.send(b"OI;");
    assert!(!a.contains("7475A") && a.ends_with('\r'));
    assert_eq!(r.send(b"OI;"), "7475A\r");
}

#[test]
fn injected_error_rejects_the_next_instruction() {
    let mut r = Rig::instant();
    r.hp.fail_next(Some(3));
    assert_eq!(r.send(b"SP1;OE;"), "3\r");
    assert_eq!(r.send(b"OA;"), "0,0,0\r");
    r.send(b"PD10,10;");
    assert!(r.record.strokes.is_empty(), "SP1 was rejected, so no pen");
}

#[test]
fn moves_take_plotting_time_at_the_pen_speeds() {
    let mut r = Rig::new(SimConfig::hp7475a().with_speed_scale(1.0));
    let t0 = r.now;
    r.arrive(b"SP1;PD;PA3800,0;PU;");
    // Runs until the pen drop, then reports when it is next due.
    let due = r.run().expect("busy");
    assert!(due > t0);
    let mut steps = 0;
    while let Some(t) = r.run() {
        r.now = t;
        steps += 1;
        assert!(steps < 100);
    }
    // 95 mm at 380 mm/s plus a drop and a lift of 0.1 s.
    assert!((r.record.plot_seconds - (0.25 + 0.2)).abs() < 1e-9, "{}", r.record.plot_seconds);
    assert!(r.now.duration_since(t0) >= Duration::from_millis(440));
}

#[test]
fn velocity_select_slows_the_pen() {
    let mut r = Rig::instant();
    r.send(b"SP1;VS19;PD;PA3800,0;");
    assert!((r.record.plot_seconds - (0.1 + 0.5)).abs() < 1e-9);
}

#[test]
fn power_cycle_forgets_buffer_and_state() {
    let mut r = Rig::instant();
    r.hp.set_lever(true).unwrap();
    r.arrive(b"SP1;PD100,100;\x1b.I80;;17:\x1b.N;19:");
    r.with(|hp, ctx| hp.power_cycle(ctx));
    r.hp.set_lever(false).unwrap();
    assert_eq!(r.hp.status().buffer_used, 0);
    assert!(!r.hp.hs.xon_xoff());
    assert_eq!(r.send(b"OS;"), "24\r");
}

#[test]
fn clip_handles_inside_outside_and_crossing_segments() {
    let bx = [0.0, 0.0, 10.0, 10.0];
    assert_eq!(clip([1.0, 1.0], [2.0, 2.0], bx), Some(([1.0, 1.0], [2.0, 2.0])));
    assert_eq!(clip([-5.0, 5.0], [15.0, 5.0], bx), Some(([0.0, 5.0], [10.0, 5.0])));
    assert_eq!(clip([-5.0, -5.0], [-1.0, 20.0], bx), None);
    assert_eq!(clip([3.0, 3.0], [3.0, 3.0], bx), Some(([3.0, 3.0], [3.0, 3.0])));
}

#[test]
fn random_bytes_never_panic_and_keep_the_accounting_straight() {
    let mut r = Rig::new(SimConfig::hp7475a().with_buffer_size(64).with_speed_scale(0.0));
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    for round in 0..20_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        // Mostly HP-GL-ish bytes, with ESC, digits and separators over-represented.
        let b = match x % 8 {
            0 => 0x1b,
            1 => b'.',
            2 => b"0123456789"[(x >> 8) as usize % 10],
            3 => b";:,"[(x >> 8) as usize % 3],
            4 => b"PAUDSIBEOLK@HMN"[(x >> 8) as usize % 15],
            _ => (x >> 16) as u8,
        };
        r.arrive(&[b]);
        if round % 7 == 0 {
            r.run();
        }
        assert!(r.hp.status().buffer_used <= 64);
    }
    r.run();
    r.take();
    // Whatever happened, the device still answers sensibly afterwards.
    r.arrive(b"\x1b.R\x1b.M:\x1b.K\x1b.B");
    assert_eq!(r.take(), "64\r");
}

#[test]
fn labels_end_at_the_dt_terminator_and_in_restores_etx() {
    let mut r = Rig::instant();
    r.send(b"DT#;SP1;LBhi; there#PD0,0,10,0;PU;");
    assert_eq!(r.record.strokes.len(), 1, "the label ended at '#', so PD was read");
    r.send(b"IN;SP1;LBx#PA50,50;\x03PD0,100;PU;");
    // After IN only ETX ends the label, so "PA50,50;" was label text; the
    // line to (0,100) starts at (10,0), a new stroke after the PU.
    assert_eq!(r.record.strokes.len(), 2);
    assert_eq!(r.record.strokes[1].points, vec![[10.0, 0.0], [0.0, 100.0]]);
    assert_eq!(r.send(b"OA;"), "0,100,0\r");
}

#[test]
fn an_abort_that_keeps_the_half_read_instruction() {
    // As plotsim's own 7475A: ESC.K drops a chained `OE` waiting for its letter.
    let mut r = Rig::instant();
    r.send(b"PU0,0;OE");
    assert_eq!(r.send(b"\x1b.B"), "1024\r");
    r.send(b"\x1b.K");
    assert_eq!(r.send(b"PU;"), "", "the OE went with the abort");
    // The emulator seen in the field: the half-read OE holds two bytes of
    // the buffer through ESC.K, and answers when a letter or `;` comes.
    let mut r = Rig::new(SimConfig::hp7475a().with_speed_scale(0.0).with_quirks([Quirk::AbortKeepsPartial]));
    r.send(b"PU0,0;OE");
    assert_eq!(r.send(b"\x1b.B"), "1022\r");
    r.send(b"\x1b.K");
    assert_eq!(r.send(b"\x1b.B"), "1022\r", "the buffer never drains to its size");
    assert_eq!(r.send(b";"), "0\r", "the stale marker answers");
    assert_eq!(r.send(b"\x1b.B"), "1024\r");
}

fn quirky(quirks: &[Quirk]) -> Rig {
    Rig::new(SimConfig::hp7475a().with_speed_scale(0.0).with_quirks(quirks.iter().copied()))
}

#[test]
fn a_clone_without_esc_o_or_esc_l_says_nothing_to_them_and_raises_no_error() {
    let mut r = quirky(&[Quirk::NoEscO, Quirk::NoEscL]);
    r.arrive(b"\x1b.O\x1b.L\x1b.O:");
    assert_eq!(r.take(), "", "no answer at all");
    // Nothing was stored or flagged: the next instructions read as usual.
    assert_eq!(r.send(b"\x1b.B\x1b.E"), "1024\r0\r");
    assert_eq!(r.send(b"OE;"), "0\r");
    // Only the quirk's own instruction is missing.
    let mut r = quirky(&[Quirk::NoEscL]);
    assert_eq!(r.send(b"\x1b.L\x1b.O"), "8\r");
    let mut r = quirky(&[Quirk::NoEscO]);
    assert_eq!(r.send(b"\x1b.O\x1b.L"), "1024\r");
}

#[test]
fn a_clone_without_esc_m_keeps_the_cr_terminator() {
    let mut r = quirky(&[Quirk::NoEscM]);
    r.arrive(b"\x1b.M;;;13;10:\x1b.L");
    assert_eq!(r.take(), "1024\r");
    assert_eq!(r.send(b"OI;"), "7475A\r");
    // Read, not refused: no error, and the bytes after it are not data.
    r.arrive(b"\x1b.M200;;;10:\x1b.E");
    assert_eq!(r.take(), "0\r");
    assert_eq!(r.send(b"OE;"), "0\r");
}

#[test]
fn strict_separators_make_a_bare_semicolon_or_a_line_break_error_1() {
    let mut r = quirky(&[Quirk::StrictSeparators]);
    // plotd's old sync: a bare `;` first.
    assert_eq!(r.send(b";OI;"), "7475A\r");
    assert_eq!(r.send(b"OE;"), "1\r", "the bare ';' is instruction not recognised");
    assert_eq!(r.send(b"OE;"), "0\r");
    // A line feed after an instruction, before the next one.
    assert_eq!(r.send(b"SP1;PD0,0,100,0;\nPU;OS;"), "56\r", "8 initialized + 16 ready + 32 error");
    assert_eq!(r.send(b"OE;"), "1\r");
    assert_eq!(r.send(b"PU;\r\nOE;"), "1\r", "CR and LF are one error each, and OE reads the last");
    let errors: Vec<u32> = r.record.errors.iter().map(|e| e.code).collect();
    assert_eq!(errors, [1, 1, 1, 1]);
    // The offending bytes did nothing else: the line was drawn, the pen is up.
    assert_eq!(r.record.strokes.len(), 1);
    assert_eq!(r.send(b"OA;"), "100,0,0\r");
    // Inside an instruction, CR and LF still separate parameters; `,` and
    // spaces between instructions are not errors.
    assert_eq!(r.send(b"PA200\n300;OA;"), "200,300,0\r");
    assert_eq!(r.send(b"PU;, PU; OE;"), "0\r");
    // The same bytes on a 7475A are fine.
    let mut r = Rig::instant();
    assert_eq!(r.send(b";OI;\nOE;\r\n;;OE;"), "7475A\r0\r0\r");
    assert!(r.record.errors.is_empty());
}

/// An HP plotter has no reset line: its reset is the power switch. The
/// buffer empties and answers end with CR again; the firmware's quirks stay.
#[test]
fn a_reset_is_a_power_cycle() {
    let mut r = quirky(&[Quirk::StrictSeparators]);
    r.hp.set_lever(true).unwrap();
    r.arrive(b"\x1b.M;;;13;10:SP1;PD100,100;");
    assert_eq!(r.send(b"\x1b.B"), "1010\r\n");
    r.with(|hp, ctx| hp.reset(ctx));
    r.hp.set_lever(false).unwrap();
    assert_eq!(r.send(b"\x1b.B"), "1024\r");
    assert_eq!(r.send(b"OS;"), "24\r");
    assert_eq!(r.send(b";OE;"), "1\r", "still strict");
    assert!(r.record.strokes.is_empty());
}
