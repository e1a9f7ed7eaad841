//! DESIGN invariant 4: stored parameters survive a power loss at any instant of a store.
//!
//! For every cut point k = 0, 1, 2, ... (every programmed write unit and every sector erase is
//! one step), a store is cut after k steps; after the "reboot" (a fresh dictionary at its
//! defaults, then a load) the dictionary must hold exactly the old set or exactly the new set.
//! The loop ends with the first k at which the store completes.
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use canopen_drive::od::standard::COMMUNICATION;
use canopen_drive::od::{layout, Access, DataType, DefaultValue, DeviceInfo, Dictionary, Object, Var};
use canopen_drive::storage::{device_signature, Group, ImageState, NonVolatile, Storage};
use canopen_drive_sim::flash::SimFlash;

const LOOP_SUBS: [(u8, Var); 4] = [
    (
        0,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(3)),
    ),
    (
        1,
        Var::new("Proportional gain", DataType::Unsigned16)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(100))
            .limits_unsigned(1, 60_000),
    ),
    (
        2,
        Var::new("Integral time", DataType::Real32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Real(0.01)),
    ),
    (3, Var::new("Status", DataType::Unsigned32)),
];

/// A small manufacturer area: a string, a record, an array and a 64-bit value.
static MANUFACTURER: [Object; 4] = layout([
    Object::var(
        0x2000,
        "Axis name",
        Var::new("Axis name", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(32)
            .default(DefaultValue::Text("axis")),
    ),
    Object::record(0x2001, "Velocity loop", &LOOP_SUBS),
    Object::array(
        0x2002,
        "Calibration table",
        8,
        &Var::new("Calibration point", DataType::Integer32).access(Access::ReadWrite),
    ),
    Object::var(
        0x2003,
        "Operating hours offset",
        Var::new("Operating hours offset", DataType::Unsigned64).access(Access::ReadWrite),
    ),
]);

type Od = Dictionary<2048>;
type Values = Vec<(u16, u8, Vec<u8>)>;

fn device() -> DeviceInfo {
    DeviceInfo { vendor_id: 0x1234, product_code: 0x42, ..DeviceInfo::servo_drive() }
}

fn dict() -> Od {
    Dictionary::new(&[&COMMUNICATION, &MANUFACTURER], device(), 7).unwrap()
}

fn values(od: &Od) -> Values {
    od.parameters(0..=0xFFFF)
        .map(|e| {
            let mut buf = vec![0u8; od.value_len(&e)];
            let n = od.read(&e, 0, &mut buf);
            buf.truncate(n);
            (e.index(), e.sub, buf)
        })
        .collect()
}

/// Gives every parameter of `group` a value that depends on `seed` and that a load accepts.
fn set_group(od: &mut Od, group: Group, seed: u32) {
    let entries: Vec<_> = od.parameters(group.range()).collect();
    for entry in entries {
        let key = seed.wrapping_mul(0x9E37_79B9) ^ (u32::from(entry.index()) << 8) ^ u32::from(entry.sub);
        let value: Vec<u8> = match entry.var.data_type.fixed_size() {
            Some(n) => {
                let candidates = [
                    key.to_le_bytes().iter().cycle().take(n).copied().collect::<Vec<u8>>(),
                    (seed + 1).to_le_bytes().iter().chain([0u8; 4].iter()).take(n).copied().collect(),
                ];
                candidates
                    .into_iter()
                    .find(|c| od.check_write(&entry, c).is_ok())
                    .expect("a value inside the limits")
            }
            None => {
                let text = format!("set {seed} for {:04X}", entry.index());
                text.into_bytes().into_iter().take(usize::from(entry.var.capacity)).collect()
            }
        };
        od.commit(&entry, &value);
    }
}

/// `base` with the values of `group` taken from `other`.
fn merge(base: &Values, other: &Values, group: Group) -> Values {
    base.iter().zip(other).map(|(b, o)| if group.contains(b.0) { o.clone() } else { b.clone() }).collect()
}

/// The set a reboot finds in `flash`.
fn reboot(flash: &mut SimFlash) -> (Values, ImageState) {
    let mut storage = Storage::new(flash, signature()).unwrap();
    let mut od = dict();
    let report = storage.load(&mut od, Group::All).unwrap();
    assert_eq!(report.skipped, 0);
    (values(&od), report.image)
}

fn signature() -> u32 {
    device_signature(&device(), 1)
}

/// What one cut-point sweep does to the image.
#[derive(Clone, Copy, Debug)]
enum Operation {
    Store(Group),
    RestoreDefaults(Group),
}

struct Sweep {
    cut_points: u64,
    image_words: usize,
    old_loaded: u32,
    new_loaded: u32,
}

/// Runs `operation` from the state `before` with a cut after k steps for k = 0, 1, ... until
/// it completes; after each cut, a reboot must find exactly `old` or exactly `new`.
fn sweep(before: &SimFlash, od: &Od, operation: Operation, old: &Values, new: &Values) -> Sweep {
    assert_ne!(old, new, "the sets must differ to detect a mix");
    let image_words = {
        let mut flash = before.clone();
        let mut storage = Storage::new(&mut flash, signature()).unwrap();
        let payload = match operation {
            Operation::Store(group) => storage.payload_len(od, group).unwrap(),
            Operation::RestoreDefaults(group) => {
                let empty = dict();
                storage.payload_len(&empty, group).unwrap() - empty.records_len(group.range())
            }
        };
        (32usize.max(before.write_size()) + payload).div_ceil(before.write_size())
    };
    let mut result = Sweep { cut_points: 0, image_words, old_loaded: 0, new_loaded: 0 };
    for k in 0.. {
        let mut flash = before.clone();
        flash.set_seed(k);
        flash.cut_after(k);
        let outcome = {
            let mut storage = Storage::new(&mut flash, signature()).unwrap();
            match operation {
                Operation::Store(group) => storage.store(od, group),
                Operation::RestoreDefaults(group) => storage.restore_defaults(group),
            }
        };
        let completed = flash.is_powered();
        assert_eq!(outcome.is_ok(), completed, "cut after {k}: {outcome:?}");
        flash.power_on();
        result.cut_points += 1;

        let (loaded, image) = reboot(&mut flash);
        if loaded == *old {
            assert!(!completed, "cut after {k}: a completed operation must be loaded");
            result.old_loaded += 1;
        } else if loaded == *new {
            result.new_loaded += 1;
        } else {
            panic!("cut after {k}: neither the old nor the new set ({image:?}):\n{loaded:x?}");
        }
        assert_eq!(flash.overwrites(), 0, "a unit was programmed twice");

        // The next store from whatever the cut left completes and is loaded.
        let mut storage = Storage::new(&mut flash, signature()).unwrap();
        storage.store(od, Group::All).unwrap();
        assert_eq!(reboot(&mut flash).0, values(od), "store after a cut at {k}");
        assert_eq!(flash.overwrites(), 0);

        if completed {
            break;
        }
    }
    result
}

/// Geometries: (capacity, sector, write unit).
const GEOMETRIES: [(usize, usize, usize); 4] =
    [(2048, 256, 4), (1024, 256, 1), (4096, 1024, 16), (1536, 128, 8)];

fn report(name: &str, geometry: (usize, usize, usize), sweep: &Sweep) {
    println!(
        "{name} {geometry:?}: {} cut points, image of {} write units, old set loaded {} times, new set {} times",
        sweep.cut_points, sweep.image_words, sweep.old_loaded, sweep.new_loaded
    );
    assert!(
        sweep.cut_points > sweep.image_words as u64,
        "{} cut points for {} words",
        sweep.cut_points,
        sweep.image_words
    );
    assert!(sweep.old_loaded > 0 && sweep.new_loaded > 0);
}

/// The flash after storing set 1 then set `a` (so both banks hold an image), and the dictionary
/// holding set `a`.
fn stored(geometry: (usize, usize, usize), a: u32) -> (SimFlash, Od) {
    let (capacity, erase, write) = geometry;
    let mut flash = SimFlash::new(capacity, erase, write);
    let mut od = dict();
    let mut storage = Storage::new(&mut flash, signature()).unwrap();
    set_group(&mut od, Group::All, 1);
    storage.store(&od, Group::All).unwrap();
    set_group(&mut od, Group::All, a);
    storage.store(&od, Group::All).unwrap();
    assert_eq!(reboot(&mut flash), (values(&od), ImageState::Found { sequence: 2 }));
    (flash, od)
}

#[test]
fn a_cut_store_of_all_parameters_leaves_the_old_or_the_new_set() {
    for geometry in GEOMETRIES {
        let (flash, mut od) = stored(geometry, 2);
        let a = values(&od);
        set_group(&mut od, Group::All, 3);
        let b = values(&od);
        let sweep = sweep(&flash, &od, Operation::Store(Group::All), &a, &b);
        report("store all", geometry, &sweep);
    }
}

#[test]
fn a_cut_store_of_one_group_leaves_the_old_or_the_new_set() {
    for group in [Group::Manufacturer, Group::Communication] {
        for geometry in GEOMETRIES {
            let (flash, mut od) = stored(geometry, 2);
            let a = values(&od);
            // The RAM holds new values in every group; only `group` is stored.
            set_group(&mut od, Group::All, 3);
            let b = merge(&a, &values(&od), group);
            let sweep = sweep(&flash, &od, Operation::Store(group), &a, &b);
            report(&format!("store {group:?}"), geometry, &sweep);
        }
    }
}

#[test]
fn a_cut_restore_of_defaults_leaves_the_old_or_the_new_set() {
    for geometry in GEOMETRIES {
        let (flash, od) = stored(geometry, 2);
        let a = values(&od);
        let defaults = merge(&a, &values(&dict()), Group::Manufacturer);
        let sweep = sweep(&flash, &od, Operation::RestoreDefaults(Group::Manufacturer), &a, &defaults);
        report("restore manufacturer defaults", geometry, &sweep);
    }
}

#[test]
fn a_cut_first_store_leaves_defaults_or_the_new_set() {
    for geometry in GEOMETRIES {
        let (capacity, erase, write) = geometry;
        let blank = SimFlash::new(capacity, erase, write);
        let mut od = dict();
        let defaults = values(&od);
        set_group(&mut od, Group::All, 5);
        let b = values(&od);
        let sweep = sweep(&blank, &od, Operation::Store(Group::All), &defaults, &b);
        report("first store", geometry, &sweep);
    }
}

#[test]
fn only_one_bank_written_before() {
    // Only set A stored: the other bank is blank when B is written into it.
    let geometry = GEOMETRIES[0];
    let (capacity, erase, write) = geometry;
    let mut flash = SimFlash::new(capacity, erase, write);
    let mut od = dict();
    set_group(&mut od, Group::All, 2);
    Storage::new(&mut flash, signature()).unwrap().store(&od, Group::All).unwrap();
    let a = values(&od);
    set_group(&mut od, Group::All, 3);
    let b = values(&od);
    let sweep = sweep(&flash, &od, Operation::Store(Group::All), &a, &b);
    report("store into a blank bank", geometry, &sweep);
}

#[test]
fn random_operations_with_random_cuts_track_a_model() {
    // A long run of stores and restores of random groups, each maybe cut at a random step;
    // after each, a reboot finds either the set committed before or the one the operation
    // would commit, and the model follows what was found.
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut random = move |n: u64| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng % n
    };
    let groups = [Group::All, Group::Communication, Group::Manufacturer, Group::Application];
    let defaults = values(&dict());
    for geometry in GEOMETRIES {
        let (capacity, erase, write) = geometry;
        let mut flash = SimFlash::new(capacity, erase, write);
        let mut committed = defaults.clone();
        let mut od = dict();
        let (mut cuts, mut changes) = (0, 0);
        for round in 0..300u32 {
            let group = groups[random(groups.len() as u64) as usize];
            let restore = random(4) == 0;
            let candidate = if restore {
                merge(&committed, &defaults, group)
            } else {
                set_group(&mut od, Group::All, round + 10);
                merge(&committed, &values(&od), group)
            };
            let cut = random(3) != 0;
            if cut {
                flash.set_seed(u64::from(round));
                // About twice the steps of a store: half of these cuts hit.
                flash.cut_after(random((640 / write + 4) as u64));
            }
            let outcome = {
                let mut storage = Storage::new(&mut flash, signature()).unwrap();
                if restore {
                    storage.restore_defaults(group)
                } else {
                    storage.store(&od, group)
                }
            };
            if !flash.is_powered() {
                cuts += 1;
            }
            assert_eq!(outcome.is_ok(), flash.is_powered(), "round {round}");
            flash.power_on();
            let (loaded, _) = reboot(&mut flash);
            if loaded == candidate {
                changes += u32::from(loaded != committed);
                committed = loaded;
            } else {
                assert_eq!(loaded, committed, "round {round}: neither the committed nor the new set");
                assert!(outcome.is_err(), "round {round}: a completed operation was lost");
            }
            assert_eq!(flash.overwrites(), 0);
        }
        println!("random run {geometry:?}: 300 operations, {cuts} cut, {changes} changed the stored set");
        assert!(cuts > 50 && changes > 50);
    }
}
