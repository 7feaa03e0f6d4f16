//! Issue 5's memory budgets, read from the product image's ELF program headers: what the
//! loader writes to flash (code, read-only data, the initial values of `.data`) and what
//! the statics occupy in RAM (`.data`, `.bss`, `.uninit`). The stack is measured at run
//! time instead (`stack_used_bytes` in the status, `monitor.rs`).

use object::{Object, ObjectSegment};
use supine_qemu_tests::{MONITOR_STACK_CEILING_BYTES, RAM_BUDGET_BYTES, firmware};

/// `memory.x`: RAM starts here; everything below is flash (code, then the PARAMS region).
const RAM_ORIGIN: u64 = supine_host::device::memory_map::RAM_ORIGIN as u64;
/// `memory.x`: the parameter blob's region, loaded separately, not part of the image.
const PARAMS_ORIGIN: u64 = supine_host::device::memory_map::PARAMS_ORIGIN as u64;
const FLASH_BUDGET_BYTES: u64 = 64 * 1024;
const STATIC_RAM_BUDGET_BYTES: u64 = 16 * 1024;

/// (flash bytes, static RAM bytes) of the ELF at `path`.
fn footprint(path: &std::path::Path) -> (u64, u64) {
    let data = std::fs::read(path).expect("read the image");
    let elf = object::File::parse(&*data).expect("an ELF image");
    let (mut flash, mut ram) = (0, 0);
    for segment in elf.segments() {
        let (_, file_bytes) = segment.file_range();
        let address = segment.address();
        assert!(
            !(PARAMS_ORIGIN..RAM_ORIGIN).contains(&address) || file_bytes == 0,
            "the image writes into the PARAMS region at {address:#x}"
        );
        // File bytes are loaded into flash whatever the run address (`.data`'s image too).
        flash += file_bytes;
        if address >= RAM_ORIGIN {
            ram += segment.size();
        }
    }
    (flash, ram)
}

#[test]
fn the_product_image_fits_64_kib_of_flash_and_16_kib_of_static_ram() {
    let image = firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let (flash, ram) = footprint(&image);
    println!("supine-firmware: flash {flash} B, static RAM {ram} B");
    // Something must be there: a parse that finds nothing would pass any budget.
    assert!(
        flash > 16 * 1024 && ram > 0,
        "flash {flash} B, static RAM {ram} B"
    );
    assert!(flash <= FLASH_BUDGET_BYTES, "flash {flash} B over 64 KiB");
    assert!(
        ram <= STATIC_RAM_BUDGET_BYTES,
        "static RAM {ram} B over 16 KiB"
    );
    // All RAM: the statics and the stack the QEMU tests hold the monitor to.
    let stack = u64::from(MONITOR_STACK_CEILING_BYTES);
    assert!(
        ram + stack <= RAM_BUDGET_BYTES,
        "static RAM {ram} B and a stack ceiling of {stack} B pass 16 KiB"
    );
}
