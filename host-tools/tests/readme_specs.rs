//! The specs shown in README.md build: documentation that cannot rot.

#[test]
fn every_full_spec_in_the_readme_builds() {
    let readme = include_str!("../../README.md");
    let mut built = 0;
    for (i, block) in readme.split("```toml").skip(1).enumerate() {
        let toml = block.split("```").next().unwrap_or("");
        if !toml.contains("kind =") {
            continue; // a fragment such as the `position = ...` line
        }
        host_tools::data::spec::parse(&format!("README block {}", i + 1), toml)
            .unwrap_or_else(|e| panic!("{e}\n{toml}"));
        built += 1;
    }
    // tf, linear, pcr, bp, arma, fbank.
    assert_eq!(built, 6);
}
