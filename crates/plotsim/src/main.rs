fn main() {
    eprintln!("plotsim: not built yet");
    std::process::exit(2);
}
