//! Where a coordinator or node listens and whom it connects to: a small
//! front for a Zenoh configuration.

use zenoh::Wait;

use crate::error::NodeError;

/// A session's endpoints (Zenoh locators such as `tcp/127.0.0.1:7447` or
/// `tcp/[::]:7447`). Peers are found only through them: multicast scouting
/// is off, so two rigs on one network (or two test runs on one machine)
/// never find each other by accident.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NetConfig {
    /// Endpoints to listen on (a coordinator's, typically).
    pub listen: Vec<String>,
    /// Endpoints to connect to (a node's: the coordinator's).
    pub connect: Vec<String>,
}

impl NetConfig {
    /// Listens on `endpoint`.
    pub fn listen(endpoint: impl Into<String>) -> Self {
        NetConfig { listen: vec![endpoint.into()], connect: Vec::new() }
    }

    /// Connects to `endpoint`.
    pub fn connect(endpoint: impl Into<String>) -> Self {
        NetConfig { listen: Vec::new(), connect: vec![endpoint.into()] }
    }

    /// The Zenoh configuration: peer mode, these endpoints, no multicast
    /// scouting, and connecting retried for a while (a node may start
    /// before its coordinator).
    pub fn zenoh_config(&self) -> Result<zenoh::Config, NodeError> {
        let mut config = zenoh::Config::default();
        let json = |list: &[String]| -> Result<String, NodeError> {
            for endpoint in list {
                endpoint
                    .parse::<zenoh::config::EndPoint>()
                    .map_err(|e| NodeError::Zenoh(format!("{endpoint:?}: {e}")))?;
            }
            Ok(format!("[{}]", list.iter().map(|e| format!("{e:?}")).collect::<Vec<_>>().join(",")))
        };
        let set = |config: &mut zenoh::Config, key: &str, value: &str| {
            config.insert_json5(key, value).map_err(|e| NodeError::Zenoh(format!("config {key} = {value}: {e}")))
        };
        set(&mut config, "mode", "\"peer\"")?;
        set(&mut config, "scouting/multicast/enabled", "false")?;
        set(&mut config, "listen/endpoints", &json(&self.listen)?)?;
        set(&mut config, "connect/endpoints", &json(&self.connect)?)?;
        // Keep trying the coordinator (every second, for a minute) rather
        // than failing when a node starts first.
        set(&mut config, "connect/timeout_ms", "60000")?;
        set(&mut config, "connect/exit_on_failure", "false")?;
        // Opening returns at once instead of waiting out the scouting
        // delay for peers found by scouting, which is off: the endpoints
        // connect in the background, and declarations reach a peer when it
        // connects.
        set(&mut config, "open/return_conditions/connect_scouted", "false")?;
        Ok(config)
    }

    /// Opens a Zenoh session with this configuration.
    pub fn open(&self) -> Result<zenoh::Session, NodeError> {
        zenoh::open(self.zenoh_config()?).wait().map_err(NodeError::zenoh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node connects to its coordinator's endpoint and listens nowhere;
    /// a coordinator listens on its own and connects to nobody.
    #[test]
    fn connect_and_listen_name_one_endpoint_each() {
        let endpoint = "tcp/127.0.0.1:7447";
        assert_eq!(NetConfig::connect(endpoint), NetConfig { listen: Vec::new(), connect: vec![endpoint.into()] });
        assert_eq!(NetConfig::listen(endpoint), NetConfig { listen: vec![endpoint.into()], connect: Vec::new() });
    }

    /// The Zenoh configuration, read back as JSON: a peer on exactly these
    /// endpoints, never scouting (Zenoh's default would find every peer on
    /// the network, and listen on a port of its choosing), retrying its
    /// connections for a minute, and opening without waiting for scouted
    /// peers.
    #[test]
    fn the_zenoh_config_is_a_peer_on_these_endpoints_without_scouting() {
        let net = NetConfig {
            listen: vec!["tcp/127.0.0.1:7447".into()],
            connect: vec!["tcp/127.0.0.1:7448".into(), "tcp/[::1]:7449".into()],
        };
        let config = net.zenoh_config().expect("config");
        let get = |key: &str| config.get_json(key).unwrap_or_else(|e| panic!("{key}: {e}"));
        assert_eq!(get("mode"), r#""peer""#);
        assert_eq!(get("scouting/multicast/enabled"), "false");
        assert_eq!(get("listen/endpoints"), r#"["tcp/127.0.0.1:7447"]"#);
        assert_eq!(get("connect/endpoints"), r#"["tcp/127.0.0.1:7448","tcp/[::1]:7449"]"#);
        assert_eq!(get("connect/timeout_ms"), "60000");
        assert_eq!(get("connect/exit_on_failure"), "false");
        assert_eq!(get("open/return_conditions/connect_scouted"), "false");
    }

    /// An endpoint Zenoh cannot parse is refused by name, before a session
    /// tries it.
    #[test]
    fn an_endpoint_zenoh_cannot_parse_is_refused_by_name() {
        let error = NetConfig::connect("127.0.0.1:7447").zenoh_config().expect_err("no protocol: refused");
        assert!(error.to_string().contains("\"127.0.0.1:7447\""), "{error}");
    }
}
