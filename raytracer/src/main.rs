fn main() {
    std::process::exit(hybrid_rt::cli::main());
}
