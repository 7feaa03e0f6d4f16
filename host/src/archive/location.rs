//! Where the archive is: a PostgreSQL URL, a SQLite file, or by default
//! `$XDG_DATA_HOME/supine/archive.sqlite` (else `$HOME/.local/share/supine/archive.sqlite`).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};

/// An archive's place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// A SQLite file (created with its folder when missing).
    Sqlite(PathBuf),
    /// A PostgreSQL server and database, as a `postgres://` or `postgresql://` URL.
    Postgres(String),
}

impl Location {
    /// The place `--archive` names, or the default one when it is absent.
    pub fn resolve(arg: Option<&str>) -> Result<Self> {
        match arg {
            Some(url) if url.starts_with("postgres://") || url.starts_with("postgresql://") => {
                Ok(Self::Postgres(url.to_string()))
            }
            Some(other) if other.contains("://") => {
                bail!("--archive {other}: expected a file path or a postgres:// URL")
            }
            Some(path) => Ok(Self::Sqlite(PathBuf::from(path))),
            None => Ok(Self::Sqlite(default_path()?)),
        }
    }

    /// How the place is shown in messages (a URL without its password).
    pub fn display(&self) -> String {
        match self {
            Self::Sqlite(path) => path.display().to_string(),
            Self::Postgres(url) => without_password(url),
        }
    }
}

/// `$XDG_DATA_HOME/supine/archive.sqlite`, else under `$HOME/.local/share`.
pub fn default_path() -> Result<PathBuf> {
    let data = match std::env::var_os("XDG_DATA_HOME").filter(|v| !v.is_empty()) {
        Some(dir) => PathBuf::from(dir),
        None => match std::env::var_os("HOME").filter(|v| !v.is_empty()) {
            Some(home) => Path::new(&home).join(".local/share"),
            None => bail!("neither XDG_DATA_HOME nor HOME is set: give --archive PATH"),
        },
    };
    Ok(data.join("supine").join("archive.sqlite"))
}

/// `url` with the password between `:` and `@` replaced by `***`.
fn without_password(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_string();
    };
    match rest.split_once('@') {
        Some((user_info, host)) if user_info.contains(':') => {
            let user = user_info.split(':').next().unwrap_or_default();
            format!("{scheme}://{user}:***@{host}")
        }
        _ => url.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_paths_and_passwords() {
        assert_eq!(
            Location::resolve(Some("postgres://u:secret@h:5/db")).unwrap(),
            Location::Postgres("postgres://u:secret@h:5/db".into())
        );
        assert_eq!(
            Location::resolve(Some("postgres://u:secret@h:5/db"))
                .unwrap()
                .display(),
            "postgres://u:***@h:5/db"
        );
        assert_eq!(
            Location::resolve(Some("a/b.sqlite")).unwrap(),
            Location::Sqlite("a/b.sqlite".into())
        );
        assert!(Location::resolve(Some("mysql://h/db")).is_err());
    }
}
