use raykit_device::SbtRecordData;

#[repr(C)]
#[derive(Copy, Clone, bytemuck::Zeroable, SbtRecordData)]
struct Record {
    index: u32,
    address: u64,
}

fn main() {}
