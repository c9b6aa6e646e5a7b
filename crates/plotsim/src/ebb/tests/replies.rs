//! Every reply syntax, byte for byte, as the firmware prints it (`printf`
//! formats of 2.8.1, `print_command` / `print_line_ending` of 3.0.2).

use super::Rig;
use crate::ebb::firmware::Firmware;

/// Sends each command to a fresh board and checks the exact reply.
fn check(fw: Firmware, setup: &str, cases: &[(&str, &str)]) {
    let mut r = Rig::new(fw);
    r.send(setup);
    for (command, want) in cases {
        let got = r.send(&format!("{command}\r"));
        assert_eq!(got, *want, "{fw} {command:?}");
        r.finish(5);
        assert_eq!(r.take(), "", "{fw} {command:?}: nothing more comes");
    }
}

#[test]
fn legacy_replies_of_2_8_1() {
    check(
        Firmware::V2_8_1,
        "",
        &[
            ("V", "EBBv13_and_above EB Firmware Version 2.8.1\r\n"),
            ("QT", "\r\nOK\r\n"),
            ("ST,East EBB", "OK\r\n"),
            ("qt", "East EBB\r\nOK\r\n"),
            ("EM,1,1", "OK\r\n"),
            ("QE", "16,16\n\rOK\r\n"),
            ("SM,100,80,-80", "OK\r\n"),
            ("QS", "80,-80\n\rOK\r\n"),
            ("QM", "QM,0,0,0,0\n\r"),
            ("QG", "D0\r\n"),
            ("QP", "1\n\rOK\r\n"),
            ("QR", "0\r\nOK\r\n"),
            ("QB", "0\r\nOK\r\n"),
            ("QC", "0394,0300\r\nOK\r\n"),
            ("ES", "0,0,0,0,0\n\rOK\r\n"),
            ("SL,200", "OK\r\n"),
            ("QL", "-56\r\nOK\r\n"),
            ("PI,B,2", "PI,1\r\n"),
            ("CS", "OK\r\n"),
            // No jerk moves before 3.0.
            ("T3,1,0,0,0,0,0,0,3", "!8 Err: Unknown command 'T3:5433'\r\n!7 Err: Extra parameter\r\n"),
            ("R", "OK\r\nOK\r\n"),
            ("CU,1,0", ""),
            ("SC,4,20000", ""),
            ("QS", "0,0\n\r"),
            ("CU,1,1", "OK\r\n"),
        ],
    );
}

#[test]
fn legacy_replies_of_3_0_2() {
    check(
        Firmware::V3_0_2,
        "",
        &[
            ("V", "EBBv13_and_above EB Firmware Version 3.0.2\r\n"),
            ("QT", "\r\nOK\r\n"),
            ("ST,East EBB", "OK\r\n"),
            ("QT", "East EBB\r\nOK\r\n"),
            ("EM,1,1", "OK\r\n"),
            ("QE", "16,16\n\rOK\r\n"),
            ("SM,100,80,-80", "OK\r\n"),
            ("QS", "80,-80\n\rOK\r\n"),
            ("QM", "QM,0,0,0,0\n\r"),
            ("QG", "10\r\n"),
            ("QP", "1\n\rOK\r\n"),
            ("QR", "0\n\rOK\r\n"),
            ("QB", "0\r\nOK\r\n"),
            ("QC", "394,300\r\nOK\r\n"),
            ("ES", "0\n\rOK\r\n"),
            ("SL,200,3", "OK\r\n"),
            ("QL,3", "200\r\nOK\r\n"),
            ("PI,B,2", "PI,1\r\n"),
            // plotink's ebb3_motion clears the accumulators so.
            ("T3,1,0,0,0,0,0,0,3", "OK\r\n"),
            ("L3,0,10,0,1000,0,0,0,0", "OK\r\n"),
            ("R", "OK\r\n"),
            ("CU,1,0", "\r\n"),
            ("QS", "0,0\n\r\r\n"),
        ],
    );
}

#[test]
fn future_syntax_of_3_0_2() {
    check(
        Firmware::V3_0_2,
        "ST,East EBB\r",
        &[
            // Switching prints only the line end: the name went out (in legacy, as nothing) before.
            ("CU,10,1", "\n"),
            ("V", "V,EBBv13_and_above EB Firmware Version 3.0.2\n"),
            ("QT", "QT,East EBB\n"),
            ("EM,1,1", "EM\n"),
            ("SM,100,80,-80", "SM\n"),
            ("QS", "QS,80,-80\n"),
            ("QM", "QM,0,0,0,0\n"),
            ("QG", "QG,10\n"),
            ("QE", "QE,16,16\n"),
            ("QC", "QC,394,300\n"),
            ("ES", "ES,0\n"),
            ("SP,1", "SP\n"),
            ("PI,B,2", "PI,1\n"),
            ("CU,2,1", "CU\n"),
            // Switching back: the name went out in future syntax, the OK in legacy.
            ("CU,10,0", "CUOK\r\n"),
        ],
    );
}

#[test]
fn errors_as_each_firmware_words_them() {
    for fw in Firmware::ALL {
        let v3 = fw.is_v3();
        let cases: Vec<(&str, String)> = vec![
            ("SM,100", "!4 Err: Missing parameter(s)\r\n".into()),
            ("SM,100X", "!5 Err: Need comma next, found: 'X'\r\n".into()),
            ("EM,300,1", "!6 Err: Invalid parameter value\r\n".into()),
            ("SP,1,2,3,4", "OK\r\n!7 Err: Extra parameter\r\n".into()),
            ("ZZ", "!8 Err: Unknown command 'ZZ:5A5A'\r\n".into()),
            ("Z,1", "!8 Err: Unknown command 'Z:5A'\r\n!7 Err: Extra parameter\r\n".into()),
            ("CU,1,7", "OK\r\n!6 Err: Invalid parameter value\r\n".into()),
            // EM without its second argument does nothing and says nothing.
            ("EM,1", String::new()),
        ];
        let mut r = Rig::new(fw);
        // A line end first thing after power-on is a command whose letter is
        // the CR (later ones follow a command's own line end and are ignored).
        let cr = if v3 { "!8 Err: Unknown command '\r:0D'\r\n" } else { "!8 Err: Unknown command '\r: D'\r\n" };
        assert_eq!(r.send("\r"), cr, "{fw}");
        assert_eq!(r.send("\r\n\r"), "", "{fw}");
        for (command, want) in &cases {
            let got = r.send(&format!("{command}\r"));
            assert_eq!(&got, want, "{fw} {command:?}");
        }
        let numbers: Vec<u32> = r.record.errors.iter().map(|e| e.code).collect();
        assert_eq!(numbers, [8, 4, 5, 6, 7, 8, 8, 7, 6], "{fw}: the record lists every error printed");
    }
    // Rate errors: 2.8.1 prints its reason and no OK; 3.0.2 prints its
    // reason and then the OK anyway.
    let mut r = Rig::new(Firmware::V2_8_1);
    assert_eq!(r.send("SM,1,100\r"), "!0 Err: <axis1> step rate > 25K steps/second.\n\r");
    assert_eq!(r.send("SM,6000,10,20\r"), "OK\r\n");
    assert_eq!(r.send("SM,1311000,1\r"), "!0 Err: <axis1> step rate < 1.31Hz.\n\r");
    let mut r = Rig::new(Firmware::V3_0_2);
    assert_eq!(r.send("SM,1,100\r"), "!0 Err: <axis1> step rate too high.\n\rOK\r\n");
    assert_eq!(r.send("SM,0,100\r"), "OK\r\n!6 Err: Invalid parameter value\r\n");
    // In future syntax 3.0.2 had already printed the command's name.
    assert_eq!(r.send("CU,10,1\rSM,100\r"), "\nSM!4 Err: Missing parameter(s)\n");
}

#[test]
fn garbage_replaces_the_next_reply_and_keeps_its_line_end() {
    let mut r = Rig::new(Firmware::V2_8_1);
    r.garble = true;
    let g = r.send("QG\r");
    assert!(g.ends_with("\r\n") && !g.starts_with("D0"), "{g:?}");
    assert_eq!(r.send("QG\r"), "D0\r\n");
}
