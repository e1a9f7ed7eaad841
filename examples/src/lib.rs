//! Examples of using canopen-drive.
