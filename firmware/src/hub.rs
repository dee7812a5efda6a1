//! The model hub: the model loaded at boot, its run-time state, and the
//! offsets it last produced.
//!
//! [`Hub::load`] decodes the blob in a model slot. A slot holds one
//! self-delimiting blob (12-byte header with the body length at offset 8,
//! body, 4-byte CRC; see `model_core::blob`) followed by whatever the rest
//! of the flash sector holds (0xFF after an erase), so [`blob_len`] reads the
//! length from the header before [`model_core::decode`] checks everything.
//! An erased slot, a damaged blob or an invalid model leave the hub without a
//! model: it then reports zero offsets, which is the machine uncompensated.
//!
//! [`Hub::on_sample`] steps the model once per sample. A sample the model
//! refuses (a missing sensor reads as NaN) changes nothing: the hub holds the
//! last good offsets and counts the fault. No path returns a non-finite
//! offset, so nothing but finite numbers ever reaches the CNC.

use model_core::blob::{HEADER_LEN, MAX_BLOB_LEN, TRAILER_LEN};
use model_core::model::StepError;
use model_core::{BlobError, ModelSlot, ModelState, ValidModel};

pub use crate::offsets::{Offsets, MAX_INPUTS, MAX_OUTPUTS};

// The hub's buffers are sized by the offsets module; they must hold what
// model-core can produce.
const _: () = assert!(MAX_INPUTS == model_core::model::MAX_CHANNELS);
const _: () = assert!(MAX_OUTPUTS == model_core::model::MAX_OUTPUTS);

/// Samples the model refused, by cause (saturating counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults {
    /// An input was NaN or infinite (a sensor missing or broken).
    pub missing_input: u32,
    /// An input was finite but beyond `model_core::model::MAX_INPUT_MAGNITUDE`
    /// (a broken conversion).
    pub out_of_range: u32,
    /// The inputs were finite but an output overflowed.
    pub overflow: u32,
    /// Anything else (wrong number of readings: a bug in the caller).
    pub other: u32,
    /// Refused samples since the last good one (0 after a good sample).
    pub consecutive: u32,
}

impl Faults {
    /// All refused samples.
    pub fn total(&self) -> u32 {
        self.missing_input
            .saturating_add(self.out_of_range)
            .saturating_add(self.overflow)
            .saturating_add(self.other)
    }

    fn count(&mut self, error: StepError) {
        let counter = match error {
            StepError::NonFiniteInput { .. } => &mut self.missing_input,
            StepError::InputOutOfRange { .. } => &mut self.out_of_range,
            StepError::NonFiniteOutput => &mut self.overflow,
            _ => &mut self.other,
        };
        *counter = counter.saturating_add(1);
        self.consecutive = self.consecutive.saturating_add(1);
    }
}

/// Length of the blob at the start of `slot`, read from its header and
/// bounded by [`MAX_BLOB_LEN`] and the slot's size.
///
/// The result is only a length to hand to [`model_core::decode`], which
/// checks magic, version, length and CRC itself: an erased slot (0xFF...)
/// gives a length that decodes to [`BlobError::BadMagic`], a header that
/// claims more than fits gives [`BlobError::LengthMismatch`], and a slot
/// shorter than a header gives [`BlobError::TooShort`].
pub fn blob_len(slot: &[u8]) -> usize {
    let limit = slot.len().min(MAX_BLOB_LEN);
    let declared = match slot.get(8..12) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => return limit,
    };
    usize::try_from(declared)
        .ok()
        .and_then(|body| body.checked_add(HEADER_LEN + TRAILER_LEN))
        .map_or(limit, |total| total.min(limit))
}

/// The model (if any), its state, and the last good offsets.
#[derive(Clone, Debug)]
pub struct Hub {
    /// The model, decoded where it lies (model-core's `ModelSlot`).
    model: ModelSlot,
    /// `ValidModel::positional_outputs`, once at load.
    positional: u8,
    /// What running the model leaves behind, fresh at every load.
    run: Run,
}

/// What running a model leaves behind: its state, the last good outputs,
/// the faults.
#[derive(Clone, Debug)]
struct Run {
    state: ModelState,
    offsets: [f64; MAX_OUTPUTS],
    slopes: [f64; MAX_OUTPUTS],
    faults: Faults,
    last_fault: Option<StepError>,
    /// `ValidModel::extrapolation` after the last good step.
    extrapolation: f64,
}

impl Run {
    /// Before the first sample.
    fn new() -> Self {
        Self {
            state: ModelState::new(),
            offsets: [0.0; MAX_OUTPUTS],
            slopes: [0.0; MAX_OUTPUTS],
            faults: Faults::default(),
            last_fault: None,
            extrapolation: 0.0,
        }
    }
}

impl Hub {
    /// Decodes the blob at the start of `slot` (a whole model slot, or any
    /// prefix holding the blob). Never fails: without a valid model the hub
    /// reports zero offsets, and [`Hub::load_error`] says why.
    pub fn load(slot: &[u8]) -> Self {
        let mut hub = Self::empty();
        hub.reload(slot);
        hub
    }

    /// A hub without a model ([`Hub::load_error`]: [`BlobError::TooShort`],
    /// as for an empty slot), built where it is returned to: the hub's
    /// stack holds it once (load into it with [`Hub::reload`]).
    pub fn empty() -> Self {
        Self {
            model: ModelSlot::new(),
            positional: 0,
            run: Run::new(),
        }
    }

    /// [`Hub::load`] into this hub, where its model lies: the model never
    /// passes through the stack (docs/firmware-cost.md, "Stack"). The
    /// state starts afresh, as in a new hub.
    pub fn reload(&mut self, slot: &[u8]) {
        let blob = slot.get(..blob_len(slot)).unwrap_or(&[]);
        // A refused blob is kept as the load error.
        let _ = self.reload_split(&[], blob);
    }

    /// [`Hub::reload`] of the blob `head ++ tail` (exactly the blob, in two
    /// parts: an upload's held-back first bytes and the rest in flash);
    /// why it was refused, if it was.
    pub fn reload_split(&mut self, head: &[u8], tail: &[u8]) -> Result<(), BlobError> {
        let loaded = self.model.load_split(head, tail);
        self.start_afresh();
        loaded
    }

    /// Everything but the model as in a hub that just loaded it (the next
    /// sample is the run's first).
    pub fn start_afresh(&mut self) {
        self.positional = self.model().map_or(0, |m| m.positional_outputs());
        self.run = Run::new();
    }

    /// The loaded model.
    pub fn model(&self) -> Option<&ValidModel> {
        self.model.model().ok()
    }

    /// Bit `j` set: output `j` is positional (sent as a slope).
    pub fn positional(&self) -> u8 {
        self.positional
    }

    /// Why no model was loaded.
    pub fn load_error(&self) -> Option<BlobError> {
        self.model.model().err()
    }

    /// Readings [`Hub::on_sample`] expects: one per model input (0 without a model).
    pub fn input_count(&self) -> usize {
        self.model().map_or(0, |m| m.inputs().len())
    }

    /// Offsets the model produces (0 without a model).
    pub fn output_count(&self) -> usize {
        self.model().map_or(0, |m| m.outputs().len())
    }

    /// Whether the model has taken a sample (its references are set).
    pub fn started(&self) -> bool {
        self.run.state.started()
    }

    /// Whether the last good sample's inputs lay outside the model's
    /// calibration envelope by more than `EXTRAPOLATION_FLAG_AT` (10 % of
    /// an input's calibration range); false for a model without bounds.
    pub fn extrapolating(&self) -> bool {
        self.run.extrapolation > model_core::model::EXTRAPOLATION_FLAG_AT
    }

    /// Mends the memories of `input`, lost for `lost` samples with
    /// `values.0` standing in and back at `values.1`
    /// ([`model_core::ValidModel::bridge`]; nothing without a model).
    pub fn bridge(&mut self, input: usize, values: (f64, f64), lost: u32) {
        if let Ok(model) = self.model.model() {
            model.bridge(&mut self.run.state, input, values, lost);
        }
    }

    /// Refused samples so far.
    pub fn faults(&self) -> Faults {
        self.run.faults
    }

    /// Why the last refused sample was refused.
    pub fn last_fault(&self) -> Option<StepError> {
        self.run.last_fault
    }

    /// One sample: `readings` holds one raw value per model input, in the
    /// model's input order ([`Hub::input_count`] of them; NaN for a channel
    /// that could not be read). Steps the model and returns its outputs, or,
    /// if the model refuses the sample, the last good offsets (zero before
    /// the first good sample and without a model). Never non-finite.
    pub fn on_sample(&mut self, readings: &[f64]) -> Offsets {
        let Ok(model) = self.model.model() else {
            return Offsets::ZERO;
        };
        let positional = self.positional;
        let mut out = [0.0; MAX_OUTPUTS];
        let mut slopes = [0.0; MAX_OUTPUTS];
        let result = model
            .step(&mut self.run.state, readings, &mut out)
            .and_then(|()| {
                if positional != 0 {
                    model.thermal_slopes(&self.run.state, readings, &mut slopes)?;
                }
                // A positional output's thermal part is zero at the
                // reference position; its geometric part is the CNC's own
                // pitch compensation. What it needs is the slope.
                for (j, v) in out.iter_mut().enumerate() {
                    if positional & (1 << j) != 0 {
                        *v = 0.0;
                    }
                }
                // `step` already guarantees finite outputs; checked again
                // here because this is the last stop before the CNC.
                if out.iter().chain(&slopes).all(|v| v.is_finite()) {
                    Ok(())
                } else {
                    Err(StepError::NonFiniteOutput)
                }
            });
        match result {
            Ok(()) => {
                self.run.extrapolation = model.extrapolation(&self.run.state, readings);
                self.run.offsets = out;
                self.run.slopes = slopes;
                self.run.faults.consecutive = 0;
                Offsets {
                    values: out,
                    slopes,
                    fresh: true,
                }
            }
            Err(e) => {
                self.run.faults.count(e);
                self.run.last_fault = Some(e);
                Offsets {
                    values: self.run.offsets,
                    slopes: self.run.slopes,
                    fresh: false,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{first_order_tf, name, vec};
    use model_core::linear::{Coef, Linear, LinearOutput};
    use model_core::{Channel, Model, Params, Reference};

    fn channel(n: &str, reference: Reference) -> Channel {
        Channel {
            name: name(n),
            reference,
        }
    }

    /// dx = 1 + 2 T1 - 0.5 T2, dz = -3 + 0.25 T2 (T2 measured against 20 C).
    fn linear_model() -> ValidModel {
        let coef = |channel, value| Coef { channel, value };
        Model {
            inputs: vec(&[
                channel("T1", Reference::Absolute),
                channel("T2", Reference::Value(20.0)),
            ]),
            outputs: vec(&[name("dx_um"), name("dz_um")]),
            dt_s: 0.0,
            params: Params::Linear(Linear {
                outputs: vec(&[
                    LinearOutput {
                        output: 0,
                        intercept: 1.0,
                        coef: vec(&[coef(0, 2.0), coef(1, -0.5)]),
                        position: None,
                    },
                    LinearOutput {
                        output: 1,
                        intercept: -3.0,
                        coef: vec(&[coef(1, 0.25)]),
                        position: None,
                    },
                ]),
            }),
            bounds: None,
            five_point: None,
        }
        .validate()
        .unwrap()
    }

    /// Seed 004's first-order lag on the spindle temperature.
    fn tf_model() -> ValidModel {
        first_order_tf("T_spindle", 1.0)
    }

    /// A 128 KiB slot as the board sees it: the blob, then erased flash.
    fn slot_with(model: &ValidModel) -> (Vec<u8>, usize) {
        let mut slot = vec![0xFF; 128 * 1024];
        let n = model_core::encode(model, &mut slot).unwrap();
        (slot, n)
    }

    fn assert_finite(o: &Offsets) {
        assert!(o.values.iter().all(|v| v.is_finite()), "{o:?}");
    }

    #[test]
    fn valid_blob_in_an_erased_slot_loads() {
        let model = linear_model();
        let (slot, n) = slot_with(&model);
        assert_eq!(blob_len(&slot), n);
        let hub = Hub::load(&slot);
        assert_eq!(hub.load_error(), None);
        assert_eq!(hub.model(), Some(&model));
        assert_eq!(hub.model().unwrap().kind().name(), "linear");
        assert_eq!((hub.input_count(), hub.output_count()), (2, 2));
        // Exactly the blob, no erased tail, loads too.
        assert_eq!(Hub::load(&slot[..n]).model(), Some(&model));
    }

    #[test]
    fn tf_blob_loads_and_runs() {
        let model = tf_model();
        let (slot, _) = slot_with(&model);
        let mut hub = Hub::load(&slot);
        assert_eq!(hub.model().map(|m| m.kind().name()), Some("tf"));
        // Starts in steady state at the first sample's temperature: zero.
        assert_eq!(hub.on_sample(&[25.0]).values, [0.0; MAX_OUTPUTS]);
        // A 1 K step: y = (0.1 * 1 + 0.4 * 0) / 0.5 = 0.2, then 0.2 + 0.8 * 0.2.
        let o = hub.on_sample(&[26.0]);
        assert!(o.fresh);
        assert!((o.values[0] - 0.2).abs() < 1e-12, "{o:?}");
        let o = hub.on_sample(&[26.0]);
        assert!((o.values[0] - 0.36).abs() < 1e-12, "{o:?}");
    }

    #[test]
    fn erased_slot_gives_no_model_and_zero_offsets() {
        let slot = vec![0xFF; 128 * 1024];
        assert_eq!(blob_len(&slot), MAX_BLOB_LEN);
        let mut hub = Hub::load(&slot);
        assert_eq!(hub.load_error(), Some(BlobError::BadMagic));
        assert!(hub.model().is_none());
        assert_eq!(hub.input_count(), 0);
        let o = hub.on_sample(&[]);
        assert_eq!(o, Offsets::ZERO);
        // Readings are ignored without a model, whatever they are.
        assert_eq!(hub.on_sample(&[f64::NAN, 1.0]), Offsets::ZERO);
        assert_eq!(hub.faults(), Faults::default());
    }

    #[test]
    fn short_or_empty_slot_gives_no_model() {
        assert_eq!(Hub::load(&[]).load_error(), Some(BlobError::TooShort));
        assert_eq!(
            Hub::load(&[0xFF; 11]).load_error(),
            Some(BlobError::TooShort)
        );
    }

    #[test]
    fn corrupted_blob_gives_no_model_and_zero_offsets() {
        let (mut slot, n) = slot_with(&linear_model());
        slot[n / 2] ^= 0x01;
        let mut hub = Hub::load(&slot);
        assert!(
            matches!(hub.load_error(), Some(BlobError::BadCrc { .. })),
            "{:?}",
            hub.load_error()
        );
        assert_eq!(hub.on_sample(&[30.0, 30.0]), Offsets::ZERO);
    }

    #[test]
    fn truncated_blob_gives_no_model() {
        let (slot, n) = slot_with(&linear_model());
        let hub = Hub::load(&slot[..n - 1]);
        assert!(
            matches!(hub.load_error(), Some(BlobError::LengthMismatch { .. })),
            "{:?}",
            hub.load_error()
        );
    }

    #[test]
    fn oversized_length_in_header_is_bounded() {
        let (mut slot, _) = slot_with(&linear_model());
        slot[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(blob_len(&slot), MAX_BLOB_LEN);
        assert!(matches!(
            Hub::load(&slot).load_error(),
            Some(BlobError::LengthMismatch {
                declared: u32::MAX,
                ..
            })
        ));
    }

    #[test]
    fn finite_readings_give_the_model_outputs() {
        let model = linear_model();
        let (slot, _) = slot_with(&model);
        let mut hub = Hub::load(&slot);
        let o = hub.on_sample(&[10.0, 24.0]);
        assert!(o.fresh);
        // dx = 1 + 2*10 - 0.5*(24-20) = 19, dz = -3 + 0.25*4 = -2.
        assert_eq!(o.values, [19.0, -2.0, 0.0, 0.0]);
        // Same as stepping the model directly.
        let mut state = ModelState::new();
        let mut direct = [0.0; 2];
        model.step(&mut state, &[10.0, 24.0], &mut direct).unwrap();
        assert_eq!(&o.values[..2], &direct);
        assert_eq!(hub.faults(), Faults::default());
    }

    #[test]
    fn nan_readings_hold_the_last_good_offsets_and_count_faults() {
        let (slot, _) = slot_with(&linear_model());
        let mut hub = Hub::load(&slot);

        // Before any good sample: zeros held.
        let o = hub.on_sample(&[f64::NAN, f64::NAN]);
        assert_eq!(o, Offsets::ZERO);
        assert_eq!(
            hub.last_fault(),
            Some(StepError::NonFiniteInput { channel: 0 })
        );

        let good = hub.on_sample(&[10.0, 24.0]);
        assert_eq!(hub.faults().consecutive, 0);

        for k in 1..=3 {
            let o = hub.on_sample(&[10.0, f64::NAN]);
            assert_eq!(o.values, good.values);
            assert!(!o.fresh);
            assert_finite(&o);
            assert_eq!(hub.faults().consecutive, k);
        }
        let o = hub.on_sample(&[f64::INFINITY, 1.0]);
        assert_eq!(o.values, good.values);
        assert_eq!(
            hub.last_fault(),
            Some(StepError::NonFiniteInput { channel: 0 })
        );
        assert_eq!(
            hub.faults(),
            Faults {
                missing_input: 5,
                out_of_range: 0,
                overflow: 0,
                other: 0,
                consecutive: 4
            }
        );

        // Recovery: fresh outputs, consecutive count cleared, totals kept.
        let o = hub.on_sample(&[11.0, 24.0]);
        assert!(o.fresh);
        assert_eq!(o.values[0], 21.0);
        assert_eq!(hub.faults().consecutive, 0);
        assert_eq!(hub.faults().total(), 5);
    }

    #[test]
    fn wrong_reading_count_and_absurd_readings_hold_offsets() {
        let (slot, _) = slot_with(&linear_model());
        let mut hub = Hub::load(&slot);
        let good = hub.on_sample(&[10.0, 24.0]);
        assert_eq!(hub.on_sample(&[10.0]).values, good.values);
        assert_eq!(hub.on_sample(&[]).values, good.values);
        // A finite but absurd reading (a broken conversion) is refused.
        let o = hub.on_sample(&[f64::MAX, 24.0]);
        assert_eq!(o.values, good.values);
        assert_finite(&o);
        let f = hub.faults();
        assert_eq!((f.other, f.out_of_range, f.total()), (2, 1, 3));
    }

    #[test]
    fn no_reading_ever_gives_non_finite_offsets() {
        let (slot, _) = slot_with(&tf_model());
        let mut hub = Hub::load(&slot);
        let specials = [
            0.0,
            -1e308,
            1e308,
            f64::MAX,
            f64::MIN,
            f64::NAN,
            f64::INFINITY,
            25.0,
        ];
        for a in specials {
            for b in specials {
                assert_finite(&hub.on_sample(&[a]));
                assert_finite(&hub.on_sample(&[b]));
            }
        }
    }
}
