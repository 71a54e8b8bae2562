pub mod chi2;
