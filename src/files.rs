//! Small file-system helpers shared by every writer.

use std::path::Path;

/// Gives a finished temporary file (which `tempfile` creates with mode 0600) the mode of a
/// normally created file, 0644, before it is renamed into place.
pub fn make_shareable(path: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o644))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        Ok(())
    }
}
