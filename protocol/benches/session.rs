//! What sealing costs: a message encoded and decoded as a plain frame against the same
//! message sealed and opened (keyed BLAKE3 over its number and bytes, both directions'
//! work), for a frame state's size and for a holodeck sample packet's.
//!
//! `cargo bench -p holocave-protocol --bench session`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use holocave_protocol::frame::{MAX_FRAME_BYTES, decode, encode};
use holocave_protocol::session::SessionKeys;

fn session(c: &mut Criterion) {
    let keys = SessionKeys::derive(b"bench session");
    let mut g = c.benchmark_group("session");
    // A frame state of four walls and two eyes is about 1.3 kB; a packet of 4096 samples
    // (16-byte records) 64 kB.
    for bytes in [1_300usize, 65_536] {
        let msg = serde_bytes::ByteBuf::from(vec![7u8; bytes]);
        g.throughput(Throughput::Bytes(bytes as u64));
        g.bench_with_input(BenchmarkId::new("plain", bytes), &msg, |b, m| {
            b.iter(|| {
                let f = encode(black_box(m), MAX_FRAME_BYTES).unwrap();
                black_box(decode::<serde_bytes::ByteBuf>(&f[4..]).unwrap())
            })
        });
        g.bench_with_input(BenchmarkId::new("sealed", bytes), &msg, |b, m| {
            let (mut seal, _) = keys.connector();
            let (_, mut open) = keys.acceptor();
            b.iter(|| {
                let f = seal.seal(black_box(m), MAX_FRAME_BYTES).unwrap();
                black_box(open.open::<serde_bytes::ByteBuf>(&f[4..]).unwrap())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, session);
criterion_main!(benches);
