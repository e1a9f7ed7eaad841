// A plain classic CAN frame standing in for a firmware's frame type, for the tests and the
// crate example (which includes this file, hence no `use` and no inner doc comments).

/// A classic CAN frame: identifier, data or remote, up to 8 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TestFrame {
    id: embedded_can::Id,
    remote: bool,
    dlc: usize,
    data: [u8; 8],
}

impl embedded_can::Frame for TestFrame {
    fn new(id: impl Into<embedded_can::Id>, data: &[u8]) -> Option<Self> {
        let mut bytes = [0; 8];
        bytes.get_mut(..data.len())?.copy_from_slice(data);
        Some(TestFrame { id: id.into(), remote: false, dlc: data.len(), data: bytes })
    }

    fn new_remote(id: impl Into<embedded_can::Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| TestFrame { id: id.into(), remote: true, dlc, data: [0; 8] })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, embedded_can::Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> embedded_can::Id {
        self.id
    }

    fn dlc(&self) -> usize {
        self.dlc
    }

    fn data(&self) -> &[u8] {
        let len = if self.remote { 0 } else { self.dlc };
        self.data.get(..len).unwrap_or(&[])
    }
}
