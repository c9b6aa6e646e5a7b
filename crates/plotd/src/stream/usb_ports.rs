//! Finding an EiBotBoard among the USB serial ports, for `port = "auto"`
//! and `nickname = "..."`: the kernel's view of each tty (`/sys/class/tty/NAME/device/..`: the USB
//! device's `idVendor`, `idProduct`, `product`, `serial`), read from a sysfs
//! root the caller names, so a test can build a tree of its own.

use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The EiBotBoard's USB vendor id (Microchip, as Evil Mad Scientist uses it).
pub const EBB_VENDOR_ID: u16 = 0x04D8;
/// The EiBotBoard's USB product id.
pub const EBB_PRODUCT_ID: u16 = 0xFD92;

/// The `port` that asks for the one EiBotBoard plugged in.
pub const AUTO_PORT: &str = "auto";

/// The port to open for a plotter's `port`: itself, or for
/// [`AUTO_PORT`] the one EiBotBoard among the USB serial ports under
/// `sysfs` (normally `/sys`), asked afresh at each connect.
///
/// # Errors
/// For `auto`, when there is no board or several.
pub fn port_to_open(port: &Path, sysfs: &Path) -> Result<PathBuf, AutoPortError> {
    if port != Path::new(AUTO_PORT) {
        return Ok(port.to_owned());
    }
    the_one_ebb(&usb_serial_ports(sysfs))
}

/// A tty that is a USB device, as sysfs describes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UsbSerialPort {
    /// The device node, `/dev/NAME`.
    pub path: PathBuf,
    /// USB vendor id.
    pub vendor_id: u16,
    /// USB product id.
    pub product_id: u16,
    /// The product string, when the device gives one.
    pub product: Option<String>,
    /// The serial number string, when the device gives one.
    pub serial: Option<String>,
}

impl UsbSerialPort {
    /// Whether this is an EiBotBoard (its vendor and product ids).
    #[must_use]
    pub fn is_ebb(&self) -> bool {
        self.vendor_id == EBB_VENDOR_ID && self.product_id == EBB_PRODUCT_ID
    }
}

impl fmt::Display for UsbSerialPort {
    /// `/dev/ttyACM0 (04d8:fd92 "EiBotBoard", serial 123)`: what a person
    /// needs to tell two boards apart.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({:04x}:{:04x}", self.path.display(), self.vendor_id, self.product_id)?;
        if let Some(p) = &self.product {
            write!(f, " {p:?}")?;
        }
        if let Some(s) = &self.serial {
            write!(f, ", serial {s}")?;
        }
        f.write_str(")")
    }
}

/// The USB serial ports under `sysfs` (normally `/sys`), by device name.
/// A tty that is not a USB device (a built-in UART, a pty) has no USB ids
/// beside its device and is left out; so is one whose ids do not parse.
#[must_use]
pub fn usb_serial_ports(sysfs: &Path) -> Vec<UsbSerialPort> {
    let Ok(entries) = std::fs::read_dir(sysfs.join("class/tty")) else {
        return Vec::new();
    };
    let mut ports: Vec<_> = entries
        .filter_map(Result::ok)
        .filter_map(|entry| {
            // `device` is a link to the USB interface; its parent is the
            // USB device, where the ids are (the kernel resolves the link
            // before the `..`).
            let usb = entry.path().join("device/..");
            let read = |name: &str| std::fs::read_to_string(usb.join(name)).ok().map(|s| s.trim().to_owned());
            let id = |name: &str| read(name).and_then(|s| u16::from_str_radix(&s, 16).ok());
            // sysfs writes a `/` of the device's name as `!` (`pts!3`).
            let name = entry.file_name().to_string_lossy().replace('!', "/");
            Some(UsbSerialPort {
                path: Path::new("/dev").join(name),
                vendor_id: id("idVendor")?,
                product_id: id("idProduct")?,
                product: read("product"),
                serial: read("serial"),
            })
        })
        .collect();
    ports.sort_by(|a, b| a.path.cmp(&b.path));
    ports
}

/// Why `port = "auto"` names no port: a cause a person can act on.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum AutoPortError {
    /// No USB serial port is an EiBotBoard.
    #[error("no EiBotBoard found (seen: {})", seen_list(.seen))]
    NoBoard {
        /// The USB serial ports there are.
        seen: Vec<UsbSerialPort>,
    },
    /// More than one is: which one is meant must be said.
    #[error("several EiBotBoards: {}; name one by its port", seen_list(.boards))]
    Several {
        /// The boards.
        boards: Vec<UsbSerialPort>,
    },
}

fn seen_list(ports: &[UsbSerialPort]) -> String {
    if ports.is_empty() {
        return "no USB serial ports".to_owned();
    }
    ports.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
}

/// The EiBotBoards among the USB serial ports under `sysfs`: the
/// candidates a `nickname` is asked of.
#[must_use]
pub fn ebb_ports(sysfs: &Path) -> Vec<UsbSerialPort> {
    usb_serial_ports(sysfs).into_iter().filter(UsbSerialPort::is_ebb).collect()
}

/// An EiBotBoard asked its nickname (`QT`), and what it answered: the name,
/// or why it did not (it did not answer, its port would not open).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SeenBoard {
    /// The board's port.
    pub port: UsbSerialPort,
    /// Its nickname, or why there is none.
    pub answer: Result<String, String>,
}

impl fmt::Display for SeenBoard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.answer {
            Ok(name) => write!(f, "{} named {name:?}", self.port),
            Err(why) => write!(f, "{} not answering: {why}", self.port),
        }
    }
}

/// Why `nickname = "..."` names no port: a cause a person can act on.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum NicknameError {
    /// No EiBotBoard answered the nickname.
    #[error("no EiBotBoard with nickname {nickname:?} found (seen: {})", seen_boards(.seen))]
    NotFound {
        /// The nickname asked for.
        nickname: String,
        /// Every EiBotBoard asked, and its answer.
        seen: Vec<SeenBoard>,
    },
    /// Several did: the boards must be renamed (`ST`) apart.
    #[error("several EiBotBoards with nickname {nickname:?}: {}; give each its own name", seen_boards(.boards))]
    Several {
        /// The nickname asked for.
        nickname: String,
        /// The boards that answered it.
        boards: Vec<SeenBoard>,
    },
}

fn seen_boards(boards: &[SeenBoard]) -> String {
    if boards.is_empty() {
        return "no EiBotBoards".to_owned();
    }
    boards.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
}

/// The port of the one board in `seen` whose nickname is `nickname`.
///
/// # Errors
/// When none answered it, or several.
pub fn the_named_ebb(nickname: &str, seen: Vec<SeenBoard>) -> Result<PathBuf, NicknameError> {
    let named: Vec<_> = seen.iter().filter(|b| b.answer.as_deref() == Ok(nickname)).cloned().collect();
    match named.as_slice() {
        [] => Err(NicknameError::NotFound { nickname: nickname.to_owned(), seen }),
        [one] => Ok(one.port.path.clone()),
        _ => Err(NicknameError::Several { nickname: nickname.to_owned(), boards: named }),
    }
}

/// The one EiBotBoard among `ports`.
///
/// # Errors
/// When there is none, or several.
pub fn the_one_ebb(ports: &[UsbSerialPort]) -> Result<PathBuf, AutoPortError> {
    let boards: Vec<_> = ports.iter().filter(|p| p.is_ebb()).cloned().collect();
    match boards.as_slice() {
        [] => Err(AutoPortError::NoBoard { seen: ports.to_vec() }),
        [one] => Ok(one.path.clone()),
        _ => Err(AutoPortError::Several { boards }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;

    /// A fake sysfs: `class/tty/NAME/device` links to a USB interface whose
    /// parent directory is the USB device with its ids, as the kernel lays
    /// out a CDC ACM tty; `ids` None makes a tty with no USB parent.
    fn tty(root: &Path, name: &str, ids: Option<(&str, &str, Option<&str>, Option<&str>)>) {
        let class = root.join("class/tty").join(name);
        std::fs::create_dir_all(&class).unwrap();
        let Some((vendor, product_id, product, serial)) = ids else {
            return;
        };
        let usb = root.join("devices/usb1").join(format!("1-{name}"));
        let interface = usb.join(format!("1-{name}:1.0"));
        std::fs::create_dir_all(&interface).unwrap();
        std::fs::write(usb.join("idVendor"), format!("{vendor}\n")).unwrap();
        std::fs::write(usb.join("idProduct"), format!("{product_id}\n")).unwrap();
        if let Some(p) = product {
            std::fs::write(usb.join("product"), format!("{p}\n")).unwrap();
        }
        if let Some(s) = serial {
            std::fs::write(usb.join("serial"), format!("{s}\n")).unwrap();
        }
        symlink(&interface, class.join("device")).unwrap();
    }

    #[test]
    fn usb_ttys_are_read_with_their_ids_and_others_left_out() {
        let root = tempfile::tempdir().unwrap();
        tty(root.path(), "ttyACM1", Some(("04d8", "fd92", Some("EiBotBoard"), Some("A1"))));
        tty(root.path(), "ttyUSB0", Some(("0403", "6001", Some("FT232R USB UART"), None)));
        tty(root.path(), "ttyS0", None);
        tty(root.path(), "ttyACM9", Some(("nonsense", "fd92", None, None)));
        let ports = usb_serial_ports(root.path());
        assert_eq!(
            ports,
            vec![
                UsbSerialPort {
                    path: "/dev/ttyACM1".into(),
                    vendor_id: 0x04D8,
                    product_id: 0xFD92,
                    product: Some("EiBotBoard".into()),
                    serial: Some("A1".into()),
                },
                UsbSerialPort {
                    path: "/dev/ttyUSB0".into(),
                    vendor_id: 0x0403,
                    product_id: 0x6001,
                    product: Some("FT232R USB UART".into()),
                    serial: None,
                },
            ]
        );
        assert!(ports[0].is_ebb() && !ports[1].is_ebb());
    }

    #[test]
    fn auto_is_asked_of_sysfs_at_each_connect_and_a_path_is_kept() {
        let root = tempfile::tempdir().unwrap();
        let auto = Path::new(AUTO_PORT);
        assert_eq!(port_to_open(Path::new("/dev/ttyUSB3"), root.path()), Ok(PathBuf::from("/dev/ttyUSB3")));
        let e = port_to_open(auto, root.path()).unwrap_err();
        assert_eq!(e.to_string(), "no EiBotBoard found (seen: no USB serial ports)");
        tty(root.path(), "ttyACM2", Some(("04d8", "fd92", Some("EiBotBoard"), None)));
        assert_eq!(port_to_open(auto, root.path()), Ok(PathBuf::from("/dev/ttyACM2")));
    }

    /// A device whose name holds a `/` is listed by sysfs with a `!` in
    /// its place (`pts!3` is `/dev/pts/3`).
    #[test]
    fn a_bang_in_a_sysfs_name_is_a_slash_in_dev() {
        let root = tempfile::tempdir().unwrap();
        tty(root.path(), "pts!3", Some(("04d8", "fd92", Some("EiBotBoard"), None)));
        assert_eq!(usb_serial_ports(root.path())[0].path, PathBuf::from("/dev/pts/3"));
    }

    /// `nickname = "..."`: the EiBotBoards under a fake sysfs are the
    /// candidates (other USB serial ports are not asked); the one whose
    /// `QT` answered the nickname is opened, and none or several is a cause
    /// naming what each board answered.
    #[test]
    fn a_nickname_picks_the_board_that_answered_it() {
        let root = tempfile::tempdir().unwrap();
        tty(root.path(), "ttyACM0", Some(("04d8", "fd92", Some("EiBotBoard"), Some("A"))));
        tty(root.path(), "ttyUSB0", Some(("0403", "6001", Some("FT232R USB UART"), None)));
        tty(root.path(), "ttyACM1", Some(("04d8", "fd92", Some("EiBotBoard"), None)));
        let boards = ebb_ports(root.path());
        assert_eq!(boards.iter().map(|b| b.path.clone()).collect::<Vec<_>>(), [PathBuf::from("/dev/ttyACM0"), "/dev/ttyACM1".into()]);
        let seen = |answers: [Result<&str, &str>; 2]| -> Vec<SeenBoard> {
            boards
                .iter()
                .zip(answers)
                .map(|(port, a)| SeenBoard { port: port.clone(), answer: a.map(str::to_owned).map_err(str::to_owned) })
                .collect()
        };
        assert_eq!(the_named_ebb("right", seen([Ok("left"), Ok("right")])), Ok(PathBuf::from("/dev/ttyACM1")));
        let e = the_named_ebb("middle", seen([Ok("left"), Err("no answer to EBB V")])).unwrap_err();
        assert_eq!(
            e.to_string(),
            "no EiBotBoard with nickname \"middle\" found (seen: /dev/ttyACM0 (04d8:fd92 \"EiBotBoard\", serial A) named \"left\", \
             /dev/ttyACM1 (04d8:fd92 \"EiBotBoard\") not answering: no answer to EBB V)"
        );
        let e = the_named_ebb("x", Vec::new()).unwrap_err();
        assert_eq!(e.to_string(), "no EiBotBoard with nickname \"x\" found (seen: no EiBotBoards)");
        let e = the_named_ebb("left", seen([Ok("left"), Ok("left")])).unwrap_err();
        assert!(e.to_string().starts_with("several EiBotBoards with nickname \"left\": /dev/ttyACM0"), "{e}");
    }

    #[test]
    fn no_sysfs_is_no_ports() {
        assert!(usb_serial_ports(Path::new("/nonexistent/sys")).is_empty());
    }

    #[test]
    fn auto_takes_the_one_ebb_and_refuses_none_or_several_listing_them() {
        let root = tempfile::tempdir().unwrap();
        tty(root.path(), "ttyUSB0", Some(("0403", "6001", Some("FT232R USB UART"), None)));
        let e = the_one_ebb(&usb_serial_ports(root.path())).unwrap_err();
        assert_eq!(e.to_string(), "no EiBotBoard found (seen: /dev/ttyUSB0 (0403:6001 \"FT232R USB UART\"))");
        assert_eq!(the_one_ebb(&[]).unwrap_err().to_string(), "no EiBotBoard found (seen: no USB serial ports)");

        tty(root.path(), "ttyACM0", Some(("04d8", "fd92", Some("EiBotBoard"), Some("123"))));
        assert_eq!(the_one_ebb(&usb_serial_ports(root.path())), Ok(PathBuf::from("/dev/ttyACM0")));

        tty(root.path(), "ttyACM1", Some(("04D8", "FD92", Some("EiBotBoard"), None)));
        let e = the_one_ebb(&usb_serial_ports(root.path())).unwrap_err();
        assert_eq!(
            e.to_string(),
            "several EiBotBoards: /dev/ttyACM0 (04d8:fd92 \"EiBotBoard\", serial 123), /dev/ttyACM1 (04d8:fd92 \"EiBotBoard\"); \
             name one by its port"
        );
    }
}
