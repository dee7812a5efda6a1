//! Why a model is refused: the one error of [`crate::model::Model::validate`]
//! and of the blob decoder's model check. Kept apart from the model so the
//! per-kind modules (fbank, bp, linear, pcr, ...) can name it without
//! importing the module that imports them.

use crate::tf::TfError;

/// Why a model is refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ModelError {
    /// A model needs at least one input and one output.
    NoInputsOrOutputs,
    /// An input or output name is empty.
    EmptyName,
    /// An input or output name holds a control character (a line break,
    /// an escape sequence): it would be printed raw by whatever shows the
    /// model.
    ControlInName,
    /// Two outputs share a name, or two inputs share name and reference.
    DuplicateName,
    /// A coefficient refers to an input or output that does not exist.
    IndexOutOfRange,
    /// A coefficient, reference or scale is NaN, infinite or beyond
    /// [`crate::capacity::MAX_MAGNITUDE`] in magnitude.
    NonFinite,
    /// Sizes do not agree (weights vs inputs, betas vs components, ...).
    ShapeMismatch,
    /// An output is computed by nothing.
    OutputUnused {
        /// Index of the output.
        output: u8,
    },
    /// The sample time is negative or not finite, or a dynamic model has none.
    BadSampleTime,
    /// A transfer function cannot be run.
    Tf {
        /// Index of the entry in the bank.
        entry: u8,
        /// What is wrong with it.
        error: TfError,
    },
    /// The ARMA forecaster's channel must be absolute (it forecasts the
    /// channel itself), its standard deviation positive, its AR part
    /// stationary and its MA part invertible.
    BadArma,
    /// A filter-bank feature has a power other than 1 or 2, or a negative
    /// time constant.
    BadFeature {
        /// Index of the feature in the bank.
        feature: u8,
    },
    /// An output has two regressions.
    DuplicateOutput {
        /// Index of the output.
        output: u8,
    },
    /// A calibration span has `min > max` (or a width beyond f64), or an
    /// error half-width is negative.
    BadBounds,
    /// Five-point geometry on a model whose outputs are not exactly
    /// `e_um`, `theta_x_urad`, `theta_y_urad`, or with `l_defl_mm` outside
    /// `0..=MAX_L_DEFL_MM`, or together with a positional output.
    BadFivePoint,
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoInputsOrOutputs => write!(f, "the model has no inputs or no outputs"),
            Self::EmptyName => write!(f, "an input or output name is empty"),
            Self::ControlInName => {
                write!(f, "an input or output name holds a control character")
            }
            Self::DuplicateName => write!(f, "an input or output name is repeated"),
            Self::IndexOutOfRange => write!(f, "a coefficient refers to a missing input/output"),
            Self::NonFinite => write!(
                f,
                "a coefficient is NaN, infinite or beyond {:e} in magnitude",
                crate::capacity::MAX_MAGNITUDE
            ),
            Self::ShapeMismatch => write!(f, "coefficient counts do not agree"),
            Self::OutputUnused { output } => write!(f, "output #{output} is computed by nothing"),
            Self::BadSampleTime => write!(f, "bad sample time (dynamic models need dt_s > 0)"),
            Self::Tf { entry, error } => write!(f, "tf entry #{entry}: {error}"),
            Self::BadArma => write!(
                f,
                "ARMA needs an absolute channel, std > 0, a stationary AR and an invertible MA part"
            ),
            Self::BadFeature { feature } => {
                write!(f, "feature #{feature}: power must be 1 or 2 and tau_s >= 0")
            }
            Self::DuplicateOutput { output } => {
                write!(f, "output #{output} has more than one regression")
            }
            Self::BadBounds => write!(
                f,
                "bounds: a span has min > max, or an error half-width is negative"
            ),
            Self::BadFivePoint => write!(
                f,
                "five-point geometry needs exactly the outputs e_um, theta_x_urad, theta_y_urad, no positional output, and 0 <= l_defl_mm <= {}",
                crate::capacity::MAX_L_DEFL_MM
            ),
        }
    }
}

impl core::error::Error for ModelError {}
