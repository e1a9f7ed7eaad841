/work/main/benches/drive-bench/target/debug/deps/canopen_drive-400ecd28594966cd.d: /work/main/crates/canopen-drive/src/lib.rs /work/main/crates/canopen-drive/src/fmt.rs /work/main/crates/canopen-drive/src/can_io.rs /work/main/crates/canopen-drive/src/cia402/mod.rs /work/main/crates/canopen-drive/src/cia402/config.rs /work/main/crates/canopen-drive/src/cia402/cyclic.rs /work/main/crates/canopen-drive/src/cia402/factor.rs /work/main/crates/canopen-drive/src/cia402/fsa.rs /work/main/crates/canopen-drive/src/cia402/hm.rs /work/main/crates/canopen-drive/src/cia402/ip.rs /work/main/crates/canopen-drive/src/cia402/objects.rs /work/main/crates/canopen-drive/src/cia402/pp.rs /work/main/crates/canopen-drive/src/cia402/probe.rs /work/main/crates/canopen-drive/src/cia402/profile.rs /work/main/crates/canopen-drive/src/cia402/slots.rs /work/main/crates/canopen-drive/src/cia402/vl.rs /work/main/crates/canopen-drive/src/comm/mod.rs /work/main/crates/canopen-drive/src/comm/emcy.rs /work/main/crates/canopen-drive/src/comm/error_control.rs /work/main/crates/canopen-drive/src/comm/heartbeat.rs /work/main/crates/canopen-drive/src/comm/lss.rs /work/main/crates/canopen-drive/src/comm/nmt.rs /work/main/crates/canopen-drive/src/comm/pdo.rs /work/main/crates/canopen-drive/src/comm/sdo_server.rs /work/main/crates/canopen-drive/src/comm/sync.rs /work/main/crates/canopen-drive/src/control/mod.rs /work/main/crates/canopen-drive/src/control/cascade.rs /work/main/crates/canopen-drive/src/control/parameters.rs /work/main/crates/canopen-drive/src/drive.rs /work/main/crates/canopen-drive/src/frame.rs /work/main/crates/canopen-drive/src/hal.rs /work/main/crates/canopen-drive/src/motion/mod.rs /work/main/crates/canopen-drive/src/motion/fixed.rs /work/main/crates/canopen-drive/src/motion/legs.rs /work/main/crates/canopen-drive/src/motion/planner.rs /work/main/crates/canopen-drive/src/motion/shape.rs /work/main/crates/canopen-drive/src/motion/solve.rs /work/main/crates/canopen-drive/src/motion/trajectory.rs /work/main/crates/canopen-drive/src/od/mod.rs /work/main/crates/canopen-drive/src/od/abort.rs /work/main/crates/canopen-drive/src/od/eds.rs /work/main/crates/canopen-drive/src/od/entry.rs /work/main/crates/canopen-drive/src/od/overrides.rs /work/main/crates/canopen-drive/src/od/persist.rs /work/main/crates/canopen-drive/src/od/standard.rs /work/main/crates/canopen-drive/src/storage/mod.rs /work/main/crates/canopen-drive/src/storage/area.rs /work/main/crates/canopen-drive/src/storage/crc32.rs /work/main/crates/canopen-drive/src/storage/image.rs /work/main/crates/canopen-drive/src/time.rs /work/main/crates/canopen-drive/src/wire/mod.rs /work/main/crates/canopen-drive/src/wire/cob_id.rs /work/main/crates/canopen-drive/src/wire/crc.rs /work/main/crates/canopen-drive/src/wire/lss.rs /work/main/crates/canopen-drive/src/wire/nmt.rs /work/main/crates/canopen-drive/src/wire/sdo.rs

/work/main/benches/drive-bench/target/debug/deps/libcanopen_drive-400ecd28594966cd.rlib: /work/main/crates/canopen-drive/src/lib.rs /work/main/crates/canopen-drive/src/fmt.rs /work/main/crates/canopen-drive/src/can_io.rs /work/main/crates/canopen-drive/src/cia402/mod.rs /work/main/crates/canopen-drive/src/cia402/config.rs /work/main/crates/canopen-drive/src/cia402/cyclic.rs /work/main/crates/canopen-drive/src/cia402/factor.rs /work/main/crates/canopen-drive/src/cia402/fsa.rs /work/main/crates/canopen-drive/src/cia402/hm.rs /work/main/crates/canopen-drive/src/cia402/ip.rs /work/main/crates/canopen-drive/src/cia402/objects.rs /work/main/crates/canopen-drive/src/cia402/pp.rs /work/main/crates/canopen-drive/src/cia402/probe.rs /work/main/crates/canopen-drive/src/cia402/profile.rs /work/main/crates/canopen-drive/src/cia402/slots.rs /work/main/crates/canopen-drive/src/cia402/vl.rs /work/main/crates/canopen-drive/src/comm/mod.rs /work/main/crates/canopen-drive/src/comm/emcy.rs /work/main/crates/canopen-drive/src/comm/error_control.rs /work/main/crates/canopen-drive/src/comm/heartbeat.rs /work/main/crates/canopen-drive/src/comm/lss.rs /work/main/crates/canopen-drive/src/comm/nmt.rs /work/main/crates/canopen-drive/src/comm/pdo.rs /work/main/crates/canopen-drive/src/comm/sdo_server.rs /work/main/crates/canopen-drive/src/comm/sync.rs /work/main/crates/canopen-drive/src/control/mod.rs /work/main/crates/canopen-drive/src/control/cascade.rs /work/main/crates/canopen-drive/src/control/parameters.rs /work/main/crates/canopen-drive/src/drive.rs /work/main/crates/canopen-drive/src/frame.rs /work/main/crates/canopen-drive/src/hal.rs /work/main/crates/canopen-drive/src/motion/mod.rs /work/main/crates/canopen-drive/src/motion/fixed.rs /work/main/crates/canopen-drive/src/motion/legs.rs /work/main/crates/canopen-drive/src/motion/planner.rs /work/main/crates/canopen-drive/src/motion/shape.rs /work/main/crates/canopen-drive/src/motion/solve.rs /work/main/crates/canopen-drive/src/motion/trajectory.rs /work/main/crates/canopen-drive/src/od/mod.rs /work/main/crates/canopen-drive/src/od/abort.rs /work/main/crates/canopen-drive/src/od/eds.rs /work/main/crates/canopen-drive/src/od/entry.rs /work/main/crates/canopen-drive/src/od/overrides.rs /work/main/crates/canopen-drive/src/od/persist.rs /work/main/crates/canopen-drive/src/od/standard.rs /work/main/crates/canopen-drive/src/storage/mod.rs /work/main/crates/canopen-drive/src/storage/area.rs /work/main/crates/canopen-drive/src/storage/crc32.rs /work/main/crates/canopen-drive/src/storage/image.rs /work/main/crates/canopen-drive/src/time.rs /work/main/crates/canopen-drive/src/wire/mod.rs /work/main/crates/canopen-drive/src/wire/cob_id.rs /work/main/crates/canopen-drive/src/wire/crc.rs /work/main/crates/canopen-drive/src/wire/lss.rs /work/main/crates/canopen-drive/src/wire/nmt.rs /work/main/crates/canopen-drive/src/wire/sdo.rs

/work/main/benches/drive-bench/target/debug/deps/libcanopen_drive-400ecd28594966cd.rmeta: /work/main/crates/canopen-drive/src/lib.rs /work/main/crates/canopen-drive/src/fmt.rs /work/main/crates/canopen-drive/src/can_io.rs /work/main/crates/canopen-drive/src/cia402/mod.rs /work/main/crates/canopen-drive/src/cia402/config.rs /work/main/crates/canopen-drive/src/cia402/cyclic.rs /work/main/crates/canopen-drive/src/cia402/factor.rs /work/main/crates/canopen-drive/src/cia402/fsa.rs /work/main/crates/canopen-drive/src/cia402/hm.rs /work/main/crates/canopen-drive/src/cia402/ip.rs /work/main/crates/canopen-drive/src/cia402/objects.rs /work/main/crates/canopen-drive/src/cia402/pp.rs /work/main/crates/canopen-drive/src/cia402/probe.rs /work/main/crates/canopen-drive/src/cia402/profile.rs /work/main/crates/canopen-drive/src/cia402/slots.rs /work/main/crates/canopen-drive/src/cia402/vl.rs /work/main/crates/canopen-drive/src/comm/mod.rs /work/main/crates/canopen-drive/src/comm/emcy.rs /work/main/crates/canopen-drive/src/comm/error_control.rs /work/main/crates/canopen-drive/src/comm/heartbeat.rs /work/main/crates/canopen-drive/src/comm/lss.rs /work/main/crates/canopen-drive/src/comm/nmt.rs /work/main/crates/canopen-drive/src/comm/pdo.rs /work/main/crates/canopen-drive/src/comm/sdo_server.rs /work/main/crates/canopen-drive/src/comm/sync.rs /work/main/crates/canopen-drive/src/control/mod.rs /work/main/crates/canopen-drive/src/control/cascade.rs /work/main/crates/canopen-drive/src/control/parameters.rs /work/main/crates/canopen-drive/src/drive.rs /work/main/crates/canopen-drive/src/frame.rs /work/main/crates/canopen-drive/src/hal.rs /work/main/crates/canopen-drive/src/motion/mod.rs /work/main/crates/canopen-drive/src/motion/fixed.rs /work/main/crates/canopen-drive/src/motion/legs.rs /work/main/crates/canopen-drive/src/motion/planner.rs /work/main/crates/canopen-drive/src/motion/shape.rs /work/main/crates/canopen-drive/src/motion/solve.rs /work/main/crates/canopen-drive/src/motion/trajectory.rs /work/main/crates/canopen-drive/src/od/mod.rs /work/main/crates/canopen-drive/src/od/abort.rs /work/main/crates/canopen-drive/src/od/eds.rs /work/main/crates/canopen-drive/src/od/entry.rs /work/main/crates/canopen-drive/src/od/overrides.rs /work/main/crates/canopen-drive/src/od/persist.rs /work/main/crates/canopen-drive/src/od/standard.rs /work/main/crates/canopen-drive/src/storage/mod.rs /work/main/crates/canopen-drive/src/storage/area.rs /work/main/crates/canopen-drive/src/storage/crc32.rs /work/main/crates/canopen-drive/src/storage/image.rs /work/main/crates/canopen-drive/src/time.rs /work/main/crates/canopen-drive/src/wire/mod.rs /work/main/crates/canopen-drive/src/wire/cob_id.rs /work/main/crates/canopen-drive/src/wire/crc.rs /work/main/crates/canopen-drive/src/wire/lss.rs /work/main/crates/canopen-drive/src/wire/nmt.rs /work/main/crates/canopen-drive/src/wire/sdo.rs

/work/main/crates/canopen-drive/src/lib.rs:
/work/main/crates/canopen-drive/src/fmt.rs:
/work/main/crates/canopen-drive/src/can_io.rs:
/work/main/crates/canopen-drive/src/cia402/mod.rs:
/work/main/crates/canopen-drive/src/cia402/config.rs:
/work/main/crates/canopen-drive/src/cia402/cyclic.rs:
/work/main/crates/canopen-drive/src/cia402/factor.rs:
/work/main/crates/canopen-drive/src/cia402/fsa.rs:
/work/main/crates/canopen-drive/src/cia402/hm.rs:
/work/main/crates/canopen-drive/src/cia402/ip.rs:
/work/main/crates/canopen-drive/src/cia402/objects.rs:
/work/main/crates/canopen-drive/src/cia402/pp.rs:
/work/main/crates/canopen-drive/src/cia402/probe.rs:
/work/main/crates/canopen-drive/src/cia402/profile.rs:
/work/main/crates/canopen-drive/src/cia402/slots.rs:
/work/main/crates/canopen-drive/src/cia402/vl.rs:
/work/main/crates/canopen-drive/src/comm/mod.rs:
/work/main/crates/canopen-drive/src/comm/emcy.rs:
/work/main/crates/canopen-drive/src/comm/error_control.rs:
/work/main/crates/canopen-drive/src/comm/heartbeat.rs:
/work/main/crates/canopen-drive/src/comm/lss.rs:
/work/main/crates/canopen-drive/src/comm/nmt.rs:
/work/main/crates/canopen-drive/src/comm/pdo.rs:
/work/main/crates/canopen-drive/src/comm/sdo_server.rs:
/work/main/crates/canopen-drive/src/comm/sync.rs:
/work/main/crates/canopen-drive/src/control/mod.rs:
/work/main/crates/canopen-drive/src/control/cascade.rs:
/work/main/crates/canopen-drive/src/control/parameters.rs:
/work/main/crates/canopen-drive/src/drive.rs:
/work/main/crates/canopen-drive/src/frame.rs:
/work/main/crates/canopen-drive/src/hal.rs:
/work/main/crates/canopen-drive/src/motion/mod.rs:
/work/main/crates/canopen-drive/src/motion/fixed.rs:
/work/main/crates/canopen-drive/src/motion/legs.rs:
/work/main/crates/canopen-drive/src/motion/planner.rs:
/work/main/crates/canopen-drive/src/motion/shape.rs:
/work/main/crates/canopen-drive/src/motion/solve.rs:
/work/main/crates/canopen-drive/src/motion/trajectory.rs:
/work/main/crates/canopen-drive/src/od/mod.rs:
/work/main/crates/canopen-drive/src/od/abort.rs:
/work/main/crates/canopen-drive/src/od/eds.rs:
/work/main/crates/canopen-drive/src/od/entry.rs:
/work/main/crates/canopen-drive/src/od/overrides.rs:
/work/main/crates/canopen-drive/src/od/persist.rs:
/work/main/crates/canopen-drive/src/od/standard.rs:
/work/main/crates/canopen-drive/src/storage/mod.rs:
/work/main/crates/canopen-drive/src/storage/area.rs:
/work/main/crates/canopen-drive/src/storage/crc32.rs:
/work/main/crates/canopen-drive/src/storage/image.rs:
/work/main/crates/canopen-drive/src/time.rs:
/work/main/crates/canopen-drive/src/wire/mod.rs:
/work/main/crates/canopen-drive/src/wire/cob_id.rs:
/work/main/crates/canopen-drive/src/wire/crc.rs:
/work/main/crates/canopen-drive/src/wire/lss.rs:
/work/main/crates/canopen-drive/src/wire/nmt.rs:
/work/main/crates/canopen-drive/src/wire/sdo.rs:

# env-dep:CARGO_PKG_VERSION=0.1.0
