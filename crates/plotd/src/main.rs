fn main() {
    eprintln!("plotd: not built yet");
    std::process::exit(2);
}
