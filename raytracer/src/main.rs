// The renderer's processors allocate small task and message buffers on
// several threads at once; glibc's allocator serialised them on an arena
// lock (futex wake-ups in the profile). mimalloc keeps per-thread heaps.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    std::process::exit(hybrid_rt::cli::main());
}
